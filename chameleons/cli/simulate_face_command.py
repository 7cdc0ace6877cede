"""``chameleons simulate-face``: a simulated phone sending a face in the real wire format."""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import cast

import click

from chameleons.cli.common import load_settings
from chameleons.launch.lifeline import die_with_parent
from chameleons.worker.ingest.livelink import rotation_factor
from chameleons.worker.simulate import (
    CuedMoves,
    FaceSample,
    Protocol_,
    SyntheticFace,
    cued_samples,
    open_sender,
    run_simulation,
    take_samples,
)
from chameleons.worker.takes import TakeError, read_take


def parse_target(target: str | None, default_port: int) -> tuple[str, int]:
    """``HOST:PORT``, ``PORT``, ``HOST`` or ``[IPv6]:PORT``; default 127.0.0.1."""
    if not target:
        return "127.0.0.1", default_port
    host, port = target, str(default_port)
    if target.startswith("["):
        host, _, rest = target[1:].partition("]")
        port = rest.removeprefix(":") or port
    elif target.isdigit():
        host, port = "127.0.0.1", target
    elif target.count(":") == 1:
        host, port = target.split(":")
    if not port.isdigit() or not 0 < int(port) < 65536:
        raise click.BadParameter(f"{target!r} is not HOST:PORT", param_hint="--target")
    return host or "127.0.0.1", int(port)


@click.command("simulate-face")
@click.option(
    "--protocol",
    type=click.Choice(["livelink", "facecapturex"]),
    default="livelink",
    show_default=True,
    help="Wire format: Live Link Face UDP or FaceCaptureX TCP.",
)
@click.option(
    "--target",
    default=None,
    metavar="HOST:PORT",
    help="Where the worker listens (default 127.0.0.1 and the protocol's port setting).",
)
@click.option(
    "--fps",
    type=click.FloatRange(1, 240),
    default=60.0,
    show_default=True,
    help="Frame rate of the synthetic face (a take plays at its own timecodes).",
)
@click.option(
    "--duration",
    type=click.FloatRange(min=0, min_open=True),
    default=None,
    metavar="S",
    help="Seconds to send (default: until Ctrl-C; a take plays once).",
)
@click.option(
    "--csv",
    "csv_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
    metavar="TAKE.csv",
    help="Replay a Live Link Face take instead.",
)
@click.option("--seed", type=int, default=0, show_default=True, help="Synthetic face seed.")
@click.option(
    "--mesh/--no-mesh",
    default=True,
    show_default=True,
    help="FaceCaptureX: include the 1220 mesh vertices (~40 KB a frame).",
)
@click.option(
    "--follow-cues",
    is_flag=True,
    help='Do the booth check\'s moves as they are cued: JSON lines {"move": "rest"|"turn"|'
    '"nod"|"copy", "seconds": S} on standard input (how `chameleons demo` drives it).',
)
def simulate_face(protocol: str, target: str | None, fps: float, duration: float | None,
                  csv_path: Path | None, seed: int, mesh: bool,
                  follow_cues: bool) -> None:  # fmt: skip
    """Send a plausible synthetic face (blinks, head sway, smiles, talking) or a Live Link
    Face take to a worker, as a phone would. Rotations use the livelink_rotation_scale
    setting, so the worker reads back the degrees that were sent."""
    die_with_parent()  # started by `chameleons demo`: never outlive it (even kill -9)
    settings = load_settings()
    default_port = settings.livelink_port if protocol == "livelink" else settings.facecapturex_port
    host, port = parse_target(target, default_port)
    samples: Iterator[FaceSample]
    if csv_path is not None:
        try:
            take = read_take(
                csv_path, rotation_factor=rotation_factor(settings.livelink_rotation_scale)
            )
        except TakeError as exc:
            raise click.ClickException(str(exc)) from exc
        samples, what = (
            take_samples(take, duration),
            f"take {csv_path.name} ({take.duration:.1f} s)",
        )
    else:
        samples, what = SyntheticFace(seed).samples(fps, duration), f"synthetic face at {fps:g} fps"
    try:
        sender = open_sender(
            cast(Protocol_, protocol), host, port, fps=fps, mesh=mesh, seed=seed,
            rotation_factor=rotation_factor(settings.livelink_rotation_scale),
        )  # fmt: skip
    except OSError as exc:
        raise click.ClickException(f"cannot connect to {host}:{port}: {exc}") from exc
    click.echo(
        f"sending {what} as {protocol} to {host}:{port}" + ("" if duration else " (Ctrl-C stops)")
    )
    if follow_cues:  # the simulated participant does what the booth check asks
        moves = CuedMoves()
        threading.Thread(target=moves.follow, args=(sys.stdin,), name="face-cues",
                         daemon=True).start()  # fmt: skip
        samples = cued_samples(samples, moves)
    stop = threading.Event()
    try:
        sent = run_simulation(sender, samples, stop=stop)
    except KeyboardInterrupt:
        stop.set()
        sent = -1
    except OSError as exc:
        raise click.ClickException(f"sending stopped: {exc}") from exc
    click.echo("stopped" if sent < 0 else f"sent {sent} frames")
