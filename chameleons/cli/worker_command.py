"""``chameleons worker``: the realtime pipeline of one booth."""

from __future__ import annotations

import dataclasses
import logging
import math
from pathlib import Path
from typing import Any

import click
import yaml

from chameleons.cli.common import load_settings
from chameleons.launch.interrupts import interrupts
from chameleons.settings import Settings
from chameleons.worker import curve
from chameleons.worker.behaviours.base import BehaviourError
from chameleons.worker.behaviours.copy import DEFAULT_DELAY
from chameleons.worker.behaviours.registry import create_behaviour
from chameleons.worker.behaviours.router import build_context
from chameleons.worker.curve import ClientKeys
from chameleons.worker.drivers import DRIVER_NAMES
from chameleons.worker.drivers.furhat_check import run_check
from chameleons.worker.renderer import RenderConfig
from chameleons.worker.runtime import WorkerConfig, run_worker


def _setting(settings: Settings, name: str, default: Any) -> Any:
    """A worker setting, or its default when this build's Settings does not have it."""
    return getattr(settings, name, default)


@click.command()
@click.option("--booth", default=None, help="Booth id (the control identity). [booth-1]")
@click.option("--driver", type=click.Choice(DRIVER_NAMES), default=None,
              help="Robot driver. [virtual]")  # fmt: skip
@click.option("--robot-url", default=None,
              help="Furhat Realtime API URL. [ws://127.0.0.1:9000/v1/events]")  # fmt: skip
@click.option("--furhat-face", "furhat_faces", multiple=True, metavar="STUDY_FACE=ROBOT_FACE",
              help="Map a study face id to the Furhat's face name (repeatable), "
                   "e.g. face-1=Isabel; over CHAMELEONS_WORKER_FURHAT_FACES.")  # fmt: skip
@click.option("--livelink-port", type=int, default=None, help="Live Link Face UDP port (0: any).")
@click.option("--facecapturex-port", type=int, default=None, help="FaceCaptureX TCP port (0: any).")
@click.option("--camera", default=None, metavar="DEVICE",
              help="Track the participant's face with a local camera instead of (or beside) "
                   "an iPhone: /dev/video0 (Linux), 0 (macOS), video=<name> (Windows), or a "
                   "video file standing in for a camera.")  # fmt: skip
@click.option("--webcam-map", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              default=None, help="The booth's iPhone-taught webcam map (chameleons "
              "webcam-calibrate) for the capture page and --camera.")  # fmt: skip
@click.option("--capture-sender", default=None, metavar="ADDRESS",
              help="Accept face capture only from this phone (IP address or host name); "
                   "default: the first phone that sends after each session start.")  # fmt: skip
@click.option("--behaviour", default="still", show_default=True,
              help="Behaviour to start in: still, natural, copy or a registered one.")  # fmt: skip
@click.option(
    "--copy-delay", type=float, default=None, help=f"Copy delay in seconds. [{DEFAULT_DELAY}]"
)
@click.option("--param", "params", multiple=True, metavar="NAME=VALUE",
              help="A parameter of the starting behaviour (repeatable), checked like a study "
                   "condition's params; VALUE is YAML: --param channels=head, "
                   "--param 'delay={uniform: [0.5, 1.0]}', --param gain=0.5.")  # fmt: skip
@click.option("--natural", "natural_path", type=click.Path(dir_okay=False, path_type=Path),
              default=None,
              help="Recording `natural` replays (take CSV, Parquet, .npz); "
                   "without it, a synthetic face.")  # fmt: skip
@click.option("--control", default=None, help="Server command endpoint (ROUTER) to connect to.")
@click.option("--telemetry", default=None, help="Server telemetry endpoint (SUB) to connect to.")
@click.option("--keys-dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="CURVE keys of the link to the server (server.key and this worker's "
                   "pair; `chameleons keys create`). [<data dir>/keys]")  # fmt: skip
@click.option("--tick-rate", type=float, default=None, help="Renderer rate in Hz. [125]")
@click.option("--face-rate", type=float, default=None, help="Face parameter rate in Hz. [25]")
@click.option("--check", is_flag=True,
              help="Log in to the Furhat, list the face mapping against the robot's faces "
                   "and exit (1 when something is wrong).")  # fmt: skip
@click.option("--renderer-process", is_flag=True,
              help="Run the renderer and robot driver in a process of their own.")  # fmt: skip
@click.option("--realtime", is_flag=True,
              help="Ask for real-time scheduling (SCHED_FIFO) for the renderer.")  # fmt: skip
@click.option("--renderer-cpu", type=int, default=None,
              help="Pin the renderer to this CPU (implies --renderer-process).")  # fmt: skip
@click.option("--lsl/--no-lsl", default=None,
              help="Publish the participant's and the robot's faces as Lab Streaming Layer "
                   "streams (docs/instruments.md). [CHAMELEONS_LSL, off]")  # fmt: skip
@click.option("-v", "--verbose", is_flag=True, help="Log at debug level.")
def worker(
    booth: str | None, driver: str | None, robot_url: str | None, furhat_faces: tuple[str, ...],
    livelink_port: int | None, capture_sender: str | None, camera: str | None,
    webcam_map: Path | None, facecapturex_port: int | None, behaviour: str,
    copy_delay: float | None, params: tuple[str, ...],
    natural_path: Path | None, control: str | None, telemetry: str | None,
    keys_dir: Path | None, tick_rate: float | None, face_rate: float | None, check: bool,
    renderer_process: bool, realtime: bool, renderer_cpu: int | None, lsl: bool | None,
    verbose: bool,
) -> None:  # fmt: skip
    """Run the realtime worker of one booth (capture -> behaviour -> renderer -> robot).

    Runs standalone too: without a server it starts in the given behaviour and drives the
    robot, so a lab can test the robot chain on its own. Ctrl-C stops it cleanly.
    """
    # Ctrl-C and SIGTERM: 130 / 143, also before the worker's own handlers are in place
    # (run_worker's stop the stages in order and report the signal the same way).
    with interrupts():
        settings = load_settings()
        logging.basicConfig(level=logging.DEBUG if verbose else settings.log_level.upper(),
                            format="%(asctime)s %(levelname)s %(name)s: %(message)s")  # fmt: skip
        config = build_config(
            settings, booth=booth, driver=driver, robot_url=robot_url,
            furhat_faces=furhat_faces, livelink_port=livelink_port,
            capture_sender=capture_sender, camera=camera,
            facecapturex_port=facecapturex_port,
            behaviour=behaviour, copy_delay=copy_delay, natural_path=natural_path,
            params=params,
            control=control, telemetry=telemetry, keys_dir=keys_dir, tick_rate=tick_rate,
            face_rate=face_rate, lsl=lsl,
        )  # fmt: skip
        if realtime or renderer_cpu is not None:
            renderer_process = True  # both are about the renderer's own process
        config = dataclasses.replace(config, renderer_process=renderer_process,
                                     renderer_realtime=realtime,
                                     renderer_cpu=renderer_cpu, webcam_map=webcam_map)  # fmt: skip
        if check:
            report = run_check(config.robot_url, config.robot_key, config.furhat_faces)
            for line in report.lines():
                click.echo(line)
            raise SystemExit(0 if report.ok else 1)
        try:
            code = run_worker(config, echo=click.echo)
        except (OSError, RuntimeError, ValueError) as exc:
            raise click.ClickException(str(exc)) from exc
        if code:
            raise SystemExit(code)


def build_config(settings: Settings, **options: Any) -> WorkerConfig:
    """Command-line options over settings over defaults."""

    def pick(option: str, setting: str, default: Any) -> Any:
        value = options.get(option)
        return value if value is not None else _setting(settings, setting, default)

    delay = float(pick("copy_delay", "worker_copy_delay", DEFAULT_DELAY))
    if not math.isfinite(delay) or delay < 0:
        raise click.BadParameter(
            "must be a non-negative number of seconds", param_hint="--copy-delay"
        )
    params: dict[str, Any] = {}
    if options.get("natural_path") is not None:
        params["path"] = str(options["natural_path"])
    elif options["behaviour"] == "natural":
        params["seed"] = 0  # standalone without a recording: the synthetic face
    given = parse_params(options.get("params") or ())
    if given:
        params.update(given)
        if options["behaviour"] == "copy" and options.get("copy_delay") is not None:
            params.setdefault("delay", delay)  # an explicit --copy-delay is checked with them
        check_behaviour(options["behaviour"], params, delay)
    render = RenderConfig(
        tick_rate=float(pick("tick_rate", "worker_tick_rate", 125.0)),
        face_rate=float(pick("face_rate", "worker_face_rate", 25.0)),
        fir_taps=int(_setting(settings, "worker_fir_taps", 15)),
        fir_cutoff_hz=float(_setting(settings, "worker_fir_cutoff_hz", 6.0)),
    )
    return WorkerConfig(
        booth=pick("booth", "worker_booth", "booth-1"),
        driver=pick("driver", "worker_driver", "virtual"),
        robot_url=pick("robot_url", "worker_robot_url", "ws://127.0.0.1:9000/v1/events"),
        robot_key=_secret(_setting(settings, "worker_robot_key", None)),
        furhat_faces={**_setting(settings, "worker_furhat_faces", {}),
                      **parse_face_map(options.get("furhat_faces") or ())},
        data_dir=settings.data_dir,
        prompts_dir=settings.prompts_dir,
        command_endpoint=pick("control", "worker_command_endpoint", "tcp://127.0.0.1:5555"),
        telemetry_endpoint=pick("telemetry", "worker_telemetry_endpoint", "tcp://127.0.0.1:5556"),
        capture_host=_setting(settings, "capture_bind_host", "0.0.0.0"),
        capture_sender=pick("capture_sender", "capture_sender", None),
        camera=pick("camera", "worker_camera", None),
        livelink_port=pick("livelink_port", "livelink_port", 11111),
        facecapturex_port=pick("facecapturex_port", "facecapturex_port", 19977),
        livelink_rotation_scale=_setting(settings, "livelink_rotation_scale", "radians"),
        mounting_rotation_deg=_setting(settings, "mounting_rotation_deg", 0.0),
        mirror=_setting(settings, "mirror", True),
        head_recentre=_setting(settings, "head_recentre", True),
        head_calibration_s=float(_setting(settings, "head_calibration_s", 20.0)),
        behaviour=options["behaviour"], behaviour_params=params, copy_delay=delay,
        render=render,
        crossfade_seconds=float(_setting(settings, "worker_crossfade_seconds", 0.3)),
        curve=_curve(settings, options),
        lsl=bool(pick("lsl", "lsl", False)),
    )  # fmt: skip


def parse_params(entries: tuple[str, ...] | list[str]) -> dict[str, Any]:
    """``("gain=0.5", "channels=[head, brows]")`` -> ``{"gain": 0.5, "channels": [...]}``:
    each VALUE read as YAML, as it would be written in the study file."""
    params: dict[str, Any] = {}
    for entry in entries:
        name, sep, text = entry.partition("=")
        name = name.strip()
        if not (sep and name and text.strip()):
            raise click.BadParameter(f"{entry!r} is not NAME=VALUE", param_hint="--param")
        try:
            params[name] = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise click.BadParameter(
                f"the value of {name} is not valid YAML ({exc.__class__.__name__})",
                param_hint="--param",
            ) from None
    return params


def check_behaviour(name: str, params: dict[str, Any], delay: float) -> None:
    """Build the behaviour once, as the worker will (the same checks as a study's
    params): a bad name or value is an error now, not when the worker starts."""
    wire = {"delay": delay, **params} if name == "copy" else params
    if name == "copy" and "delay" not in params and params.get("coexpress"):
        wire.pop("delay")
    try:
        create_behaviour(name, wire, build_context())
    except BehaviourError as exc:
        raise click.BadParameter(str(exc), param_hint="--param") from None


def _curve(settings: Settings, options: dict[str, Any]) -> ClientKeys | None:
    """The worker's CURVE keys when there are any; without, only a loopback link runs."""
    keys_dir = Path(options.get("keys_dir") or settings.keys_dir)
    name = settings.worker_key_name
    endpoints = [options.get("control") or settings.worker_command_endpoint,
                 options.get("telemetry") or settings.worker_telemetry_endpoint]  # fmt: skip
    try:
        if curve.have_client_keys(keys_dir, name):
            return curve.load_client(keys_dir, name)
        logging.getLogger(__name__).warning(curve.require_safe(endpoints, who="worker"))
    except curve.CurveError as exc:
        raise click.ClickException(str(exc)) from exc
    return None


def parse_face_map(entries: tuple[str, ...] | list[str]) -> dict[str, str]:
    """``("face-1=Isabel", ...)`` -> ``{"face-1": "Isabel"}`` (a later entry wins)."""
    faces: dict[str, str] = {}
    for entry in entries:
        study_face, sep, robot_face = (part.strip() for part in entry.partition("="))
        if not (sep and study_face and robot_face):
            raise click.BadParameter(
                f"{entry!r} is not STUDY_FACE=ROBOT_FACE", param_hint="--furhat-face"
            )
        faces[study_face] = robot_face
    return faces


def _secret(value: Any) -> str | None:
    if value is None:
        return None
    secret = value.get_secret_value() if hasattr(value, "get_secret_value") else str(value)
    return secret or None


if __name__ == "__main__":  # `python -m chameleons.cli.worker_command`: no server imports
    worker()
