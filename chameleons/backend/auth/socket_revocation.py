"""Closing the WebSockets of a staff session that has ended.

A staff WebSocket (the console's ``/ws/wizard/...`` and ``/ws/sessions/...``, a robot
display opened with a staff cookie) checks the login once, at its handshake. So that
logout, "log out everywhere" and deactivation reach the sockets already open as they reach
the cookie, every such socket is registered here under its staff session's id while it
runs, and is closed with ``4401`` and a logged reason when that session ends:

- at once, when the session ends in a server process: ``sessions.end``/``end_all`` queue
  ``{"type": "staff_sessions_ended", "ids": [...]}`` on the live hub's ``staff-sessions``
  channel for after the commit; the hub delivers it here and, on PostgreSQL, through the
  live fan-out (``events.pg_fanout``) to every other server process;
- within ``CHAMELEONS_STAFF_SOCKET_RECHECK_S`` otherwise: every process re-checks its open
  staff sockets' sessions in one query that often. That catches sessions that expire, and
  ``chameleons user deactivate`` on SQLite (a command in a process of its own, with no live
  channel to the server; on PostgreSQL the command sends the same notice by NOTIFY).

OWASP Session Management Cheat Sheet: a session ended on the server ends everything that
rode on it. An ended session never reopens, so a notice that arrives before its socket has
registered (between the handshake's check and ``watch``) is remembered for a while.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
import time
from collections.abc import AsyncIterator, Awaitable, Callable, Iterable, Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session, sessionmaker
from starlette.websockets import WebSocket

from chameleons.backend.events import guard
from chameleons.backend.events.hub import LiveHub, Message
from chameleons.backend.events.repository import publish_after_commit
from chameleons.backend.models import StaffSession, StaffUser

log = logging.getLogger(__name__)

STAFF_CHANNEL = "staff-sessions"
ENDED = "staff_sessions_ended"
SIGNED_OUT = 4401  # the code the console's handshake refusal uses too
REMEMBER_ENDED_S = 120.0


def announce_ended(db: Session, session_ids: list[int], reason: str) -> None:
    """After the commit, close the open WebSockets of these staff sessions, everywhere."""
    message = {"type": ENDED, "ids": session_ids, "reason": reason}
    publish_after_commit(db, STAFF_CHANNEL, message)


@dataclass(eq=False)
class Watch:
    """One open staff socket: ``ended`` is set (on its loop) when its session ends."""

    session_id: int
    loop: asyncio.AbstractEventLoop
    ended: asyncio.Event = field(default_factory=asyncio.Event)
    reason: str = ""

    def end(self, reason: str) -> None:
        if not self.reason:
            self.reason = reason
        self.ended.set()


class StaffSockets:
    """The open staff sockets of this process by staff session id. Thread-safe."""

    def __init__(self) -> None:
        self._open: dict[int, set[Watch]] = {}
        self._ended: dict[int, tuple[str, float]] = {}  # id -> (reason, when), recent only
        self._lock = threading.Lock()

    @contextlib.contextmanager
    def watch(self, session_id: int) -> Iterator[Watch]:
        """Register the calling socket (call from its event loop) while the block runs."""
        watch = Watch(session_id, asyncio.get_running_loop())
        with self._lock:
            self._open.setdefault(session_id, set()).add(watch)
            ended = self._ended.get(session_id)
        if ended is not None:
            watch.end(ended[0])
        try:
            yield watch
        finally:
            with self._lock:
                watches = self._open.get(session_id, set())
                watches.discard(watch)
                if not watches:
                    self._open.pop(session_id, None)

    def end(self, session_ids: Iterable[int], reason: str) -> int:
        """Close the sockets of these sessions (from any thread); how many there were."""
        now = time.monotonic()
        with self._lock:
            for stale in [k for k, (_, t) in self._ended.items() if now - t > REMEMBER_ENDED_S]:
                del self._ended[stale]
            watches: list[Watch] = []
            for session_id in session_ids:
                self._ended[session_id] = (reason, now)
                watches.extend(self._open.get(session_id, ()))
        for watch in watches:
            with contextlib.suppress(RuntimeError):  # its loop has closed: nothing to close
                watch.loop.call_soon_threadsafe(watch.end, reason)
        return len(watches)

    def open_session_ids(self) -> list[int]:
        with self._lock:
            return list(self._open)

    def remembered(self) -> int:
        """How many ended sessions are remembered (bounded by ``REMEMBER_ENDED_S``)."""
        with self._lock:
            return len(self._ended)


def staff_sockets(app: Any) -> StaffSockets:
    registry: StaffSockets = app.state.staff_sockets
    return registry


def _on_notice(registry: StaffSockets) -> Callable[[str, Message], None]:
    def listener(channel: str, message: Message) -> None:
        if channel != STAFF_CHANNEL or message.get("type") != ENDED:
            return
        ids = [int(i) for i in message.get("ids", []) if isinstance(i, int)]
        registry.end(ids, str(message.get("reason") or "ended"))

    return listener


def ended_sessions(db: Session, session_ids: list[int]) -> dict[int, str]:
    """Which of these staff sessions may no longer be used, and why."""
    rows = db.execute(
        select(
            StaffSession.id,
            StaffSession.end_reason,
            StaffSession.ended_at,
            StaffSession.expires_at,
            StaffUser.is_active,
        )
        .join(StaffUser, StaffUser.id == StaffSession.user_id)
        .where(StaffSession.id.in_(session_ids))
    )
    now = datetime.now(UTC)
    found: dict[int, str] = {}
    for session_id, end_reason, ended_at, expires_at, is_active in rows:
        if ended_at is not None:
            found[session_id] = end_reason or "ended"
        elif not is_active:
            found[session_id] = "deactivated"
        elif (expires_at if expires_at.tzinfo else expires_at.replace(tzinfo=UTC)) <= now:
            found[session_id] = "expired"
        else:
            found[session_id] = ""
    gone = {i: "account removed" for i in session_ids if i not in found}
    return {i: why for i, why in {**found, **gone}.items() if why}


def _recheck(registry: StaffSockets, factory: sessionmaker[Session]) -> None:
    session_ids = registry.open_session_ids()
    if not session_ids:
        return
    with factory() as db:
        ended = ended_sessions(db, session_ids)
    for session_id, reason in ended.items():
        registry.end([session_id], reason)


@contextlib.asynccontextmanager
async def revoking(app: Any, interval_s: float) -> AsyncIterator[None]:
    """For the server's lifetime: close sockets on notices, and re-check every interval."""
    registry = staff_sockets(app)
    hub: LiveHub = app.state.live_hub
    remove = hub.add_listener(_on_notice(registry))

    async def recheck_forever() -> None:
        while True:
            await asyncio.sleep(interval_s)
            try:
                await asyncio.to_thread(_recheck, registry, app.state.sessionmaker)
            except Exception:  # the database is away for a moment: try again next time
                log.exception("re-checking the open staff sockets' sessions failed")

    task = asyncio.create_task(recheck_forever())
    try:
        yield
    finally:
        remove()
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task


async def serve_while_signed_in(
    websocket: WebSocket, session_id: int | None, serve: Callable[[], Awaitable[None]]
) -> None:
    """Run a socket's ``serve``; if staff session ``session_id`` ends meanwhile, stop it
    and close the socket with 4401 and the reason. ``None``: not a staff socket."""
    if session_id is None:
        await serve()
        return
    with staff_sockets(websocket.app).watch(session_id) as watch:
        serving = asyncio.ensure_future(serve())
        ended = asyncio.ensure_future(watch.ended.wait())
        try:
            await asyncio.wait({serving, ended}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            ended.cancel()
            if not serving.done():
                serving.cancel()
            await asyncio.wait({serving})  # let it let go of its subscriptions and reads
    if not serving.cancelled():
        serving.result()  # the handler's own errors stay its own
        return
    closed = guard.SocketClosed(SIGNED_OUT, f"staff session ended ({watch.reason})")
    await guard.close(websocket, closed)
