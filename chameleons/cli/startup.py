"""The server's start-up for `chameleons demo`, finished before anything is printed.

The app's lifespan (binding the worker link's ZeroMQ sockets, starting the local worker)
runs inside uvicorn. :class:`QuietStartup` runs it first and calls ``on_started`` (the
welcome) only once it succeeded; a failure is kept, uvicorn's traceback of it is held back,
and :func:`serve` raises :class:`StartupError` with one sentence instead.
"""

from __future__ import annotations

import logging
import socket
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI

from chameleons.backend.bridge.wiring import WorkerLinkError
from chameleons.launch.interrupts import Interrupted, Interrupts
from chameleons.launch.web_server import WebServer, run_until_stopped, web_config
from chameleons.settings import Settings

UVICORN_ERRORS = "uvicorn.error"


class StartupError(Exception):
    """The server could not start (one sentence, for the CLI)."""


class _HoldBack(logging.Filter):
    """Keeps uvicorn's error records back until the server has started."""

    def __init__(self, server: WebServer) -> None:
        super().__init__()
        self.server = server
        self.held: list[logging.LogRecord] = []

    def filter(self, record: logging.LogRecord) -> bool:
        if self.server.started:
            return True
        self.held.append(record)
        return False


class QuietStartup(WebServer):
    def __init__(
        self, app: FastAPI, on_started: Callable[[], None], settings: Settings, **options: Any
    ) -> None:
        super().__init__(web_config(app, settings, **options))
        self.on_started = on_started
        self.failure: BaseException | None = None
        self._remember_failure(app)

    def _remember_failure(self, app: FastAPI) -> None:
        """Wrap the app's lifespan: an exception before it yields is the start-up failure."""
        original = app.router.lifespan_context

        @asynccontextmanager
        async def lifespan(running: Any) -> AsyncIterator[Any]:
            started = False
            try:
                async with original(running) as state:
                    started = True
                    yield state
            except Exception as exc:
                if not started:
                    self.failure = exc
                raise

        app.router.lifespan_context = lifespan

    async def startup(self, sockets: list[socket.socket] | None = None) -> None:
        await super().startup(sockets)
        if self.started and not self.should_exit:
            self.on_started()


def serve(server: QuietStartup, stops: Interrupts, sockets: list[socket.socket]) -> None:
    """Run ``server`` until it stops (a stop signal: :class:`Interrupted`); a start-up
    failure is :class:`StartupError`."""
    held = _HoldBack(server)
    errors = logging.getLogger(UVICORN_ERRORS)
    errors.addFilter(held)
    try:
        run_until_stopped(server, stops, sockets)
    except Interrupted:
        raise
    except SystemExit as exc:
        if server.started:
            raise
        raise StartupError(_sentence(server.failure, held.held)) from exc
    finally:
        errors.removeFilter(held)
    if not server.started:
        raise StartupError(_sentence(server.failure, held.held))


def _sentence(failure: BaseException | None, held: list[logging.LogRecord]) -> str:
    if isinstance(failure, WorkerLinkError):
        return str(failure)
    if failure is not None:
        detail = str(failure).strip().splitlines()[0] if str(failure).strip() else ""
        reason = f"{type(failure).__name__}: {detail}" if detail else type(failure).__name__
        return f"The server could not start: {reason.rstrip('.')}."
    messages = [r.getMessage().strip().splitlines()[-1] for r in held if r.getMessage().strip()]
    return f"The server could not start: {messages[0] if messages else 'no reason given'}."
