"""The uvicorn server the commands run: its options from the settings, and no signal
handlers of its own (the command's :mod:`.interrupts` stops it, see there why)."""

from __future__ import annotations

import contextlib
import socket
from collections.abc import Iterator
from typing import Any

import uvicorn
from fastapi import FastAPI

from chameleons.launch.interrupts import Interrupts
from chameleons.settings import Settings


def web_config(app: FastAPI, settings: Settings, **options: Any) -> uvicorn.Config:
    """uvicorn's configuration for ``app``. Forwarded headers are believed only from the
    proxies the settings name (uvicorn's default trusts 127.0.0.1, so any local process
    could pick the address the login throttle counts failures against)."""
    trusted = settings.forwarded_allow_ips.strip()
    return uvicorn.Config(
        app,
        proxy_headers=bool(trusted),
        forwarded_allow_ips=trusted or None,
        ws_per_message_deflate=settings.ws_compression,
        **options,
    )


class WebServer(uvicorn.Server):
    """A uvicorn server that leaves SIGINT and SIGTERM to the command (``should_exit``)."""

    @contextlib.contextmanager
    def capture_signals(self) -> Iterator[None]:
        yield

    def stop(self, again: bool = False) -> None:
        """What uvicorn's own handler does: a graceful shutdown, forced on a repeat."""
        if again:
            self.force_exit = True
        self.should_exit = True


def run_until_stopped(
    server: WebServer, stops: Interrupts, sockets: list[socket.socket] | None = None
) -> None:
    """Serve in this thread until a stop signal (then :class:`~.interrupts.Interrupted`,
    after the graceful shutdown) or until the server stops by itself."""
    stops.check()  # a signal during start-up: do not start serving at all
    with stops.stopping(server.stop, quiet=True):
        server.run(sockets=sockets)
    stops.check()
