"""`chameleons demo`: everything on this machine, with printed URLs, a QR code and logins."""

from __future__ import annotations

import subprocess
from typing import IO
from urllib.parse import urlsplit

import click
import segno
from fastapi import FastAPI
from sqlalchemy.exc import SQLAlchemyError

from chameleons.backend.app import create_app
from chameleons.backend.capture import capture_url
from chameleons.backend.display.links import current_path
from chameleons.backend.wizard import typed_speech
from chameleons.cli.common import load_settings
from chameleons.cli.heap import settle_startup_heap
from chameleons.cli.startup import QuietStartup, StartupError, serve
from chameleons.launch.embedded import (
    DataDirInUseError,
    DemoData,
    FaceSimulatorCues,
    demo_settings,
    lock_data_dir,
    prepare_demo,
    start_face_simulator,
    stop_process,
)
from chameleons.launch.interrupts import Interrupts, interrupts
from chameleons.launch.ports import ChosenPorts, PortError, choose_ports
from chameleons.settings import Settings


def _print_welcome(
    base: str,
    data: DemoData,
    display_url: str,
    ports: ChosenPorts,
    simulate_face: bool,
    webcam_url: str | None = None,
) -> None:
    phone_url = f"{base}/p/{data.phone_token}"
    settings = ports.settings
    click.echo(f"\nMechanical Chameleons demo — data in {settings.data_dir.resolve()} (SQLite)\n")
    click.echo("Open these in three browser windows (log in with the staff accounts below):")
    click.echo(f"  wizard console   {base}/wizard/sessions/{data.session_id}")
    click.echo(f"  robot display    {display_url}")
    click.echo("                   (click it once so the browser lets it play the robot's voice)")
    if webcam_url is not None:
        click.echo(f"  webcam capture   {webcam_url}")
        click.echo("                   (on the computer with the webcam: allow the camera, then"
                   " calibrate the neutral face)")  # fmt: skip
    click.echo(f"  PI dashboard     {base}/pi")
    click.echo(f"  participant      {phone_url}   (participant {data.participant_code};")
    click.echo(f"                   or type the phone code of the wizard console at {base}/join)")
    if _loopback(base):
        click.echo(
            "  These links work on this computer only. For a real phone in the same network,"
            "\n  restart with --host 0.0.0.0 and CHAMELEONS_PUBLIC_URL=http://<this computer's"
            " LAN address>:PORT\n  (the QR code below then holds that address)."
        )
    else:
        click.echo("  On a phone in the same network, scan the QR code.")
    click.echo("")
    segno.make(phone_url, error="m").terminal(compact=True)
    click.echo("Staff accounts:")
    for username, password in data.credentials.items():
        click.echo(f"  {username:<8} password: {password}")
    _print_ports(ports)
    if webcam_url is not None:
        click.echo("\nWebcam capture link as a QR code (for a laptop or tablet with a camera):")
        segno.make(webcam_url, error="m").terminal(compact=True)
    face = (
        "The webcam on the capture page is the face source (no iPhone needed)."
        if webcam_url is not None
        else "A simulated face stream stands in for the iPhone."
        if simulate_face
        else "Waiting for a real iPhone (Live Link Face or FaceCaptureX)."
    )
    click.echo(f"\n{face} Ctrl-C stops everything.\n")


def _print_ports(ports: ChosenPorts) -> None:
    settings = ports.settings
    click.echo("Ports:")
    click.echo(f"  web              {settings.host}:{settings.port}")
    click.echo(f"  iPhone face      Live Link Face UDP {settings.livelink_port}, "
               f"FaceCaptureX TCP {settings.facecapturex_port}")  # fmt: skip
    click.echo(f"  worker link      {settings.worker_command_endpoint}, "
               f"{settings.worker_telemetry_endpoint}")  # fmt: skip
    for line in ports.moved:
        click.echo(f"  ({line})")


def _warn_typed_speech(app: FastAPI) -> None:
    """The start-up's espeak-ng check, said before anyone opens the console."""
    found = typed_speech.synthesiser_of(app.state)
    if found is not None and not found.available:
        click.echo(f"Typed speech (the console's Say field) cannot speak: {found.detail}.\n")


def _loopback(base: str) -> bool:
    """Whether phones elsewhere cannot reach ``base`` (its host is this computer only)."""
    host = urlsplit(base).hostname or ""
    return host == "localhost" or host.startswith("127.") or host == "::1"


@click.command()
@click.option(
    "--host",
    default=None,
    help="Bind address (default CHAMELEONS_HOST or 127.0.0.1); 0.0.0.0 lets phones in the "
    "network connect.",
)
@click.option("--port", type=int, default=None, help="Port (default CHAMELEONS_PORT or 8000).")
@click.option(
    "--simulate-face/--no-simulate-face",
    default=True,
    show_default=True,
    help="Send a synthetic face to the local worker (off: use a real iPhone).",
)
@click.option(
    "--webcam",
    is_flag=True,
    help="The face comes from a webcam on the booth's capture page (its link is printed); "
    "no simulated face.",
)
def demo(host: str | None, port: int | None, simulate_face: bool, webcam: bool) -> None:
    """Start the whole system on its embedded default: the server on SQLite with the demo
    study and plan, a local worker driving the virtual robot, and a simulated face (or,
    with --webcam, the webcam capture page's link)."""
    # Ctrl-C and SIGTERM end it with 130 / 143 once the server, its worker and the face
    # simulator have stopped, whenever they come (chameleons.launch.interrupts).
    with interrupts() as stops:
        _run(stops, host, port, simulate_face and not webcam, webcam)


def _run(stops: Interrupts, host: str | None, port: int | None, simulate_face: bool,
         webcam: bool = False) -> None:  # fmt: skip
    # Everything that can fail is done before the welcome is printed, so a failure is the
    # first (and only) thing the user reads: the settings, the data directory, the ports,
    # the database, and the server's start-up (worker link, local worker) inside uvicorn.
    settings = demo_settings(load_settings(host=host, port=port))
    lock = _lock(settings)
    try:
        ports = _ports(settings, web_port_given=port is not None)
        settings = ports.settings
        data = _prepare(settings)
        app = _app(settings)
        base = settings.effective_public_url
        path = current_path(app, settings.embedded_worker_booth)
        display_url = base + path if path else "(retired: issue a new link on /display)"
        simulator: list[subprocess.Popen[bytes]] = []

        webcam_url = capture_url(app, settings.embedded_worker_booth) if webcam else None

        def started() -> None:
            _print_welcome(base, data, display_url, ports, simulate_face, webcam_url)
            _warn_typed_speech(app)
            if simulate_face:  # it follows the booth check's moves (the check passes on the demo)
                simulator.append(start_face_simulator(settings, follow_cues=True))
                app.state.face_cues = FaceSimulatorCues(simulator[-1],
                                                        settings.embedded_worker_booth)  # fmt: skip

        server = QuietStartup(app, started, settings, log_level="warning")
        settle_startup_heap()  # the start-up's objects out of the collector's full walks
        try:
            serve(server, stops, [ports.web])  # the socket bound above: no second bind
        except StartupError as exc:
            raise click.ClickException(str(exc)) from exc
        finally:
            for process in simulator:
                stop_process(process)
    finally:
        lock.close()


def _app(settings: Settings) -> FastAPI:
    try:
        return create_app(settings)
    except Exception as exc:  # one sentence, not a traceback, before anything is printed
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise click.ClickException(f"The server could not start: {reason}.") from exc


def _lock(settings: Settings) -> IO[str]:
    try:
        return lock_data_dir(settings.data_dir)
    except DataDirInUseError as exc:
        raise click.ClickException(str(exc)) from exc
    except OSError as exc:
        raise click.ClickException(
            f"Cannot use the data directory {settings.data_dir.resolve()}: {exc.strerror}."
        ) from exc


def _ports(settings: Settings, *, web_port_given: bool) -> ChosenPorts:
    try:
        return choose_ports(settings, web_port_given=web_port_given)
    except PortError as exc:
        raise click.ClickException(str(exc)) from exc


def _prepare(settings: Settings) -> DemoData:
    try:
        return prepare_demo(settings)
    except SQLAlchemyError as exc:
        reason = str(getattr(exc, "orig", None) or exc).splitlines()[0]
        raise click.ClickException(
            f"Cannot prepare the demo database {settings.effective_database_url}: {reason}."
        ) from exc
