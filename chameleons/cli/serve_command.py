from __future__ import annotations

import sys

import click

from chameleons.backend.app import create_app
from chameleons.backend.migrate import upgrade
from chameleons.cli.common import load_settings
from chameleons.cli.heap import settle_startup_heap
from chameleons.launch.interrupts import interrupts
from chameleons.launch.web_server import WebServer, run_until_stopped, web_config

STARTUP_FAILURE = 3  # uvicorn's status for a server that did not start (uvicorn.run's)


@click.command()
@click.option("--host", default=None, help="Bind address (default from settings: 127.0.0.1).")
@click.option("--port", type=int, default=None, help="Port (default from settings: 8000).")
@click.option(
    "--upgrade/--no-upgrade",
    "run_upgrade",
    default=True,
    show_default=True,
    help="Apply database migrations before serving.",
)
def serve(host: str | None, port: int | None, run_upgrade: bool) -> None:
    """Run the web server (wizard console, phone pages, PI dashboard, API)."""
    # Ctrl-C and SIGTERM end it with 130 / 143 after the graceful shutdown (the app's
    # lifespan stops the worker link and a supervised worker), at any moment.
    with interrupts() as stops:
        settings = load_settings(secure=True, host=host, port=port)
        if run_upgrade:
            upgrade(settings.effective_database_url)
        app = create_app(settings)
        settle_startup_heap()  # the start-up's objects out of the collector's full walks
        click.echo(f"serving on {settings.effective_public_url}")
        config = web_config(app, settings, host=settings.host, port=settings.port,
                            log_level=settings.log_level)  # fmt: skip
        server = WebServer(config)
        run_until_stopped(server, stops)
        if not server.started:
            sys.exit(STARTUP_FAILURE)  # uvicorn has logged why
