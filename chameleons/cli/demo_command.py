"""`chameleons demo`: everything on this machine, with printed URLs, a QR code and logins."""

from __future__ import annotations

import signal
import sys
from urllib.parse import urlsplit

import click
import segno
import uvicorn

from chameleons.backend.app import create_app
from chameleons.backend.display.links import current_path
from chameleons.cli.common import load_settings
from chameleons.cli.embedded import (
    DemoData,
    demo_settings,
    prepare_demo,
    start_face_simulator,
    stop_process,
)


def _print_welcome(
    base: str, data: DemoData, display_url: str, data_dir: str, simulate_face: bool
) -> None:
    phone_url = f"{base}/p/{data.phone_token}"
    click.echo(f"\nMechanical Chameleons demo — data in {data_dir} (SQLite)\n")
    click.echo("Open these in three browser windows (log in with the staff accounts below):")
    click.echo(f"  wizard console   {base}/wizard/sessions/{data.session_id}")
    click.echo(f"  robot display    {display_url}")
    click.echo("                   (click it once so the browser lets it play the robot's voice)")
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
    face = (
        "A simulated face stream stands in for the iPhone."
        if simulate_face
        else "Waiting for a real iPhone (Live Link Face or FaceCaptureX)."
    )
    click.echo(f"\n{face} Ctrl-C stops everything.\n")


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
def demo(host: str | None, port: int | None, simulate_face: bool) -> None:
    """Start the whole system on its embedded default: the server on SQLite with the demo
    study and plan, a local worker driving the virtual robot, and a simulated face."""
    settings = demo_settings(load_settings(host=host, port=port))
    data = prepare_demo(settings)
    app = create_app(settings)
    base = settings.effective_public_url
    path = current_path(app, settings.embedded_worker_booth)
    display_url = base + path if path else "(retired: issue a new link on /display)"
    _print_welcome(base, data, display_url, str(settings.data_dir.resolve()), simulate_face)
    simulator = start_face_simulator(settings) if simulate_face else None
    # uvicorn re-raises SIGTERM after its graceful shutdown; exit through `finally` then,
    # so the face simulator is stopped too (the worker stops with the app's lifespan).
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(128 + signal.SIGTERM))
    try:
        uvicorn.run(app, host=settings.host, port=settings.port, log_level="warning")
    finally:
        if simulator is not None:
            stop_process(simulator)
