"""Guards for every WebSocket (phone, console, live feed, robot display).

One client must never be able to stall the server for everybody else, so each socket gets:

- a per-socket incoming message rate (token bucket: ``ws_message_burst`` at once, then
  ``ws_message_rate`` per second); a client above it is disconnected with 1008;
- text frames only: a binary frame closes the socket with 1003 (unsupported data);
- a bounded outgoing queue with O(1) work per message (see the display's ``Subscription``
  and the hub's), and a send deadline (``ws_send_timeout_s``): a client that stops reading
  fills its TCP window, the send waits, and the client is disconnected instead of its
  backlog growing without bound.

Every such disconnect is logged with its reason (logger ``chameleons.backend.events.guard``).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections import Counter
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Any

from starlette.websockets import WebSocket, WebSocketDisconnect

from chameleons.backend.logredact import redact

log = logging.getLogger(__name__)

UNSUPPORTED_DATA = 1003  # RFC 6455 7.4.1: a type of data the endpoint cannot accept
POLICY_VIOLATION = 1008
TRY_AGAIN_LATER = 1013  # the server is shedding this client; it may reconnect


class SocketClosed(Exception):  # noqa: N818 (a close, not an error of the server)
    """Raised inside a socket's handler to close it with ``code`` and a logged ``reason``."""

    def __init__(self, code: int, reason: str) -> None:
        super().__init__(reason)
        self.code = code
        self.reason = reason


def slow_client(what: str) -> SocketClosed:
    return SocketClosed(TRY_AGAIN_LATER, f"client is not reading ({what})")


@dataclass(frozen=True)
class SocketLimits:
    queue: int = 256
    rate: float = 200.0
    burst: int = 400
    send_timeout: float = 10.0


def limits_of(websocket: WebSocket) -> SocketLimits:
    settings = getattr(websocket.app.state, "settings", None)
    if settings is None:
        return SocketLimits()
    return SocketLimits(
        queue=settings.ws_queue_limit,
        rate=settings.ws_message_rate,
        burst=settings.ws_message_burst,
        send_timeout=settings.ws_send_timeout_s,
    )


class MessageRate:
    """A token bucket: O(1) per message, no history kept."""

    def __init__(self, rate: float, burst: int) -> None:
        self.rate = rate
        self.burst = float(burst)
        self._tokens = float(burst)
        self._last = time.monotonic()

    def allow(self) -> bool:
        now = time.monotonic()
        self._tokens = min(self.burst, self._tokens + (now - self._last) * self.rate)
        self._last = now
        if self._tokens < 1.0:
            return False
        self._tokens -= 1.0
        return True


class Inbound:
    """Receives a socket's text frames under its rate limit."""

    def __init__(self, websocket: WebSocket, limits: SocketLimits | None = None) -> None:
        self._websocket = websocket
        limits = limits or limits_of(websocket)
        self._rate = MessageRate(limits.rate, limits.burst)

    async def text(self) -> str:
        """The next text frame; ``WebSocketDisconnect`` when the client has gone."""
        frame = await self._websocket.receive()
        if frame["type"] == "websocket.disconnect":
            raise WebSocketDisconnect(frame.get("code", 1000))
        if not self._rate.allow():
            raise SocketClosed(
                POLICY_VIOLATION,
                f"more than {self._rate.burst:.0f} messages at once or "
                f"{self._rate.rate:g} per second",
            )
        text = frame.get("text")
        if not isinstance(text, str):
            raise SocketClosed(UNSUPPORTED_DATA, "binary frames are not accepted")
        return text


async def send_text(websocket: WebSocket, text: str, timeout: float | None = None) -> None:
    """Send one frame; a client that does not take it within the deadline is too slow."""
    deadline = limits_of(websocket).send_timeout if timeout is None else timeout
    # asyncio.timeout, not wait_for: on Python 3.11 wait_for swallows a cancellation that
    # arrives as the send completes, and the cancelled sender would then run on forever.
    try:
        async with asyncio.timeout(deadline):
            await websocket.send_text(text)
    except TimeoutError:
        raise slow_client(f"a send waited {deadline:g} s") from None


def _describe(websocket: WebSocket) -> str:
    client = websocket.client
    peer = f"{client.host}:{client.port}" if client else "?"
    # The path only (query strings carry tokens), with the phone's token taken out too.
    return f"{redact(websocket.url.path)} from {peer}"


async def close(websocket: WebSocket, error: SocketClosed) -> None:
    log.warning("WebSocket %s closed (%d): %s", _describe(websocket), error.code, error.reason)
    counters = getattr(websocket.app.state, "socket_guard_counters", None)
    if isinstance(counters, Counter):
        counters[f"closed.{error.code}"] += 1
    # The client may not be reading: closing must not wait on it for long either.
    with contextlib.suppress(Exception):
        async with asyncio.timeout(1.0):
            await websocket.close(code=error.code, reason=error.reason[:120])


@contextlib.asynccontextmanager
async def guarded(websocket: WebSocket) -> AsyncIterator[None]:
    """Run a socket's handler; a ``SocketClosed`` from it closes the socket with its reason."""
    try:
        yield
    except SocketClosed as error:
        await close(websocket, error)


def raise_closed(tasks: Any) -> None:
    """Re-raise a ``SocketClosed`` that ended one of ``tasks`` (finished ``asyncio.Task``s)."""
    for task in tasks:
        if task.done() and not task.cancelled():
            error = task.exception()
            if isinstance(error, SocketClosed):
                raise error
