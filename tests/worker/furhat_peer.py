"""A WebSocket test peer that speaks the subset of the Furhat Realtime API the worker uses.

It answers ``request.auth`` with ``response.auth``, answers ``request.speak.audio`` with
``response.speak.start`` and (after ``speech_seconds``) ``response.speak.end``, and
records every message it receives, in order, with its arrival time.
"""

from __future__ import annotations

import asyncio
import json
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed


@dataclass(frozen=True)
class Received:
    time: float
    message: dict[str, Any]

    @property
    def type(self) -> str:
        return str(self.message.get("type"))


class FurhatPeer:
    def __init__(self, *, speech_seconds: float = 0.2) -> None:
        self.speech_seconds = speech_seconds
        self.received: list[Received] = []
        self.connections = 0
        self._cond = threading.Condition()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._server: Server | None = None
        self._live: set[ServerConnection] = set()
        self._ready = threading.Event()
        self._stop: asyncio.Event | None = None
        self._thread = threading.Thread(target=lambda: asyncio.run(self._main()), daemon=True)
        self.port = 0

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}/v1/events"

    def __enter__(self) -> FurhatPeer:
        self._thread.start()
        assert self._ready.wait(5), "furhat peer did not start"
        return self

    def __exit__(self, *_exc: object) -> None:
        assert self._loop is not None
        assert self._stop is not None
        self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(5)

    async def _main(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        async with serve(self._handle, "127.0.0.1", 0) as server:
            self._server = server
            self.port = next(iter(server.sockets)).getsockname()[1]
            self._ready.set()
            await self._stop.wait()

    async def _handle(self, ws: ServerConnection) -> None:
        self._live.add(ws)
        with self._cond:
            self.connections += 1
            self._cond.notify_all()
        try:
            async for raw in ws:
                message = json.loads(raw)
                with self._cond:
                    self.received.append(Received(time.monotonic(), message))
                    self._cond.notify_all()
                await self._answer(ws, message)
        except ConnectionClosed:
            pass
        finally:
            self._live.discard(ws)

    async def _answer(self, ws: ServerConnection, message: dict[str, Any]) -> None:
        kind = message.get("type")
        if kind == "request.auth":
            await ws.send(json.dumps({"type": "response.auth", "access": True}))
        elif kind == "request.speak.audio":
            await ws.send(json.dumps({"type": "response.speak.start"}))
            asyncio.get_running_loop().call_later(
                self.speech_seconds,
                lambda: asyncio.ensure_future(ws.send(json.dumps({"type": "response.speak.end"}))),
            )

    def drop_connections(self) -> None:
        """Close every live connection from the robot's side (the driver must reconnect)."""
        assert self._loop is not None
        for ws in list(self._live):
            asyncio.run_coroutine_threadsafe(ws.close(), self._loop).result(5)

    def of_type(self, kind: str) -> list[Received]:
        with self._cond:
            return [r for r in self.received if r.type == kind]

    def wait_for(self, predicate: Callable[[FurhatPeer], bool], timeout: float = 5.0) -> None:
        with self._cond:
            if not self._cond.wait_for(lambda: predicate(self), timeout):
                kinds = [r.type for r in self.received[-5:]]
                raise AssertionError(f"furhat peer: condition not met; last received {kinds}")
