"""Live updates across server processes through PostgreSQL's LISTEN/NOTIFY.

The live hub is in-process: with two server processes (``chameleons serve --workers 2``,
or two replicas behind a proxy) a phone answering on one would not update a console
watching on the other. When the database is PostgreSQL, every message published in this
process is also sent with ``pg_notify`` on one channel, and messages that other processes
sent are delivered here to the same subscribers and listeners (the deployment's database,
no new broker). SQLite servers are one process and keep the hub alone.

- A message is JSON ``{"o": origin, "c": channel, "m": message}``; a process ignores its
  own. NOTIFY payloads are limited to 8000 bytes: a larger message goes out as
  ``{"type": "resync"}`` for its channel, and subscribers re-read the state from the
  database (as they do when they fall behind).
- The views a commit retained (``LiveHub.retain``: the console's state and the phone's view
  as the change made them) go to the other processes too, as ``{"o", "r": channel, "v":
  views}``, before that commit's events, so a console or phone on another process takes
  them as one in the same process does instead of loading the session again. A console's
  state (about 9 kB) is sent zlib-compressed and base64-encoded (``"z"``); views too large
  even so are not sent (the other processes' readers load the session, as before).
- Phone presence (how many phones a session's link has open) is per process too; each
  process sends its whole presence map when it changes and every ``HEARTBEAT_S``, and the
  hub counts a peer's map until ``PEER_TIMEOUT_S`` passes without news (a killed process
  stops counting after that).
- Delivery is at most once and only while both processes run, as in-process: the
  database, not the live channel, is the record; pages re-read it on reconnect.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import json
import logging
import time
import uuid
import zlib
from collections.abc import AsyncIterator
from typing import Any

import psycopg
from sqlalchemy import text
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session

from chameleons.backend.events import jsontext
from chameleons.backend.events.hub import RESYNC, LiveHub, Message
from chameleons.backend.events.repository import pending_notices

log = logging.getLogger(__name__)

PG_CHANNEL = "chameleons_live"
MAX_PAYLOAD = 7900  # PostgreSQL refuses more than 8000 bytes
HEARTBEAT_S = 5.0
PEER_TIMEOUT_S = 15.0
RETRY_S = 2.0


def libpq_url(database_url: str) -> str | None:
    """The URL psycopg connects with, or None when the database is not PostgreSQL."""
    url = make_url(database_url)
    if url.get_backend_name() != "postgresql":
        return None
    return url.set(drivername="postgresql").render_as_string(hide_password=False)


def encode(origin: str, channel: str, message: Message) -> str:
    payload = jsontext.dump_bytes({"o": origin, "c": channel, "m": message})
    if len(payload) <= MAX_PAYLOAD:
        return payload.decode()
    return jsontext.dumps({"o": origin, "c": channel, "m": RESYNC})


def encode_retained(origin: str, channel: str, views: dict[str, Message]) -> str | None:
    """The payload that carries a commit's retained views to the other processes, None
    when it would not fit in a NOTIFY."""
    plain = jsontext.dump_bytes({"o": origin, "r": channel, "v": views})
    if len(plain) <= MAX_PAYLOAD:
        return plain.decode()
    # Level 1: a console's state shrinks about fourfold in tens of microseconds, on the loop.
    packed = base64.b64encode(zlib.compress(jsontext.dump_bytes(views), 1)).decode("ascii")
    compressed = jsontext.dumps({"o": origin, "r": channel, "z": packed})
    # Not sent when too large even so: the other processes' readers then find older views
    # (or none) whose version is not the newest event's, and load the session.
    return compressed if len(compressed) <= MAX_PAYLOAD else None


def decode_retained(body: dict[str, Any]) -> dict[str, Message]:
    """The views an ``encode_retained`` payload carries."""
    if "z" in body:
        views: dict[str, Message] = json.loads(zlib.decompress(base64.b64decode(body["z"])))
        return views
    return dict(body["v"])


def notify_on_commit(db: Session) -> int:
    """For commands run outside the server (``chameleons user deactivate``): send what the
    transaction queued with ``publish_after_commit`` to the running server processes, by
    NOTIFY in the same transaction, so PostgreSQL delivers it only if it commits. Nothing
    on SQLite (no channel to the server). Returns how many notices were queued."""
    if db.get_bind().dialect.name != "postgresql":
        return 0
    origin = f"command-{uuid.uuid4().hex}"
    notices = pending_notices(db)
    for channel, message in notices:
        payload = encode(origin, channel, message)
        db.execute(text("SELECT pg_notify(:pg, :payload)"), {"pg": PG_CHANNEL, "payload": payload})
    return len(notices)


class PgFanout:
    """Sends this process's messages and presence; hands the others' to the hub."""

    def __init__(self, hub: LiveHub, conninfo: str) -> None:
        self.hub = hub
        self.conninfo = conninfo
        self.origin = uuid.uuid4().hex
        # How every payload this process sends begins (``encode``: the origin comes first).
        self._own_prefix = jsontext.dumps({"o": self.origin})[:-1] + ","
        self._outbox: asyncio.Queue[str] = asyncio.Queue(maxsize=10_000)
        self.listening = asyncio.Event()
        self.dropped = 0  # messages not sent because the outbox was full
        self.backend_pids: tuple[int, int] = (0, 0)  # (listen, notify) while connected

    # --- called by the hub, on its loop ---------------------------------------------------
    def send(self, channel: str, message: Message) -> None:
        self._queue(encode(self.origin, channel, message))

    def send_retained(self, channel: str, views: dict[str, Message]) -> None:
        payload = encode_retained(self.origin, channel, views)
        if payload is not None:
            self._queue(payload)

    def send_presence(self) -> None:
        body: dict[str, Any] = {"o": self.origin, "p": self.hub.local_presence()}
        # Which phones (for the console's list of two phones on one link), when it fits.
        detailed = jsontext.dump_bytes({**body, "d": self.hub.local_details()})
        if len(detailed) <= MAX_PAYLOAD:
            self._queue(detailed.decode())
            return
        self._queue(jsontext.dumps(body))

    def _queue(self, payload: str) -> None:
        try:
            self._outbox.put_nowait(payload)
        except asyncio.QueueFull:  # PostgreSQL gone for long: drop, pages resync later
            self.dropped += 1

    # --- the tasks ----------------------------------------------------------------------------
    async def run(self) -> None:
        """Listen and send until cancelled; reconnect after a lost connection."""
        while True:
            try:
                await self._connected()
            except asyncio.CancelledError:
                raise
            except Exception as exc:  # PostgreSQL restarted, network: try again
                self.listening.clear()
                log.warning("live fan-out through PostgreSQL lost (%s); retrying", exc)
                await asyncio.sleep(RETRY_S)

    async def _connected(self) -> None:
        async with (
            await psycopg.AsyncConnection.connect(self.conninfo, autocommit=True) as listen,
            await psycopg.AsyncConnection.connect(self.conninfo, autocommit=True) as notify,
        ):
            await listen.execute(f"LISTEN {PG_CHANNEL}")
            self.backend_pids = (listen.info.backend_pid, notify.info.backend_pid)
            self.listening.set()
            self.send_presence()
            loops = (self._listen_loop(listen), self._send_loop(notify), self._heartbeat())
            parts = [asyncio.create_task(loop) for loop in loops]
            try:
                # Any part that fails (a lost connection) ends both: run() reconnects them.
                done, _ = await asyncio.wait(parts, return_when=asyncio.FIRST_COMPLETED)
                for part in done:
                    part.result()
                raise ConnectionError("listening for notifications ended")
            finally:
                for part in parts:
                    part.cancel()
                await asyncio.gather(*parts, return_exceptions=True)

    async def _listen_loop(self, connection: psycopg.AsyncConnection[Any]) -> None:
        async for note in connection.notifies():
            self._receive(note.payload)

    async def _send_loop(self, connection: psycopg.AsyncConnection[Any]) -> None:
        while True:
            payload = await self._outbox.get()
            await connection.execute("SELECT pg_notify(%s, %s)", (PG_CHANNEL, payload))

    async def _heartbeat(self) -> None:
        while True:
            await asyncio.sleep(HEARTBEAT_S)
            self.send_presence()

    def _receive(self, payload: str) -> None:
        if payload.startswith(self._own_prefix):
            return  # PostgreSQL sends this process's NOTIFYs back to it: nothing to read
        try:
            body = json.loads(payload)
            origin = body["o"]
            if origin == self.origin:
                return
            if "p" in body:
                expiry = time.monotonic() + PEER_TIMEOUT_S
                self.hub.peer_presence(origin, body["p"], expiry, body.get("d"))
            elif "r" in body:
                self.hub.retain_from_peer(str(body["r"]), decode_retained(body))
            else:
                self.hub.deliver(str(body["c"]), body["m"])
        except Exception:  # one bad notification must not stop the others
            log.exception("live fan-out: unreadable notification dropped")


@contextlib.asynccontextmanager
async def _tasks(*coroutines: Any) -> AsyncIterator[None]:
    tasks = [asyncio.create_task(c) for c in coroutines]
    try:
        yield
    finally:
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)


@contextlib.asynccontextmanager
async def fan_out(hub: LiveHub, database_url: str) -> AsyncIterator[PgFanout | None]:
    """Run the fan-out for the server's lifetime when the database is PostgreSQL."""
    conninfo = libpq_url(database_url)
    if conninfo is None:
        yield None
        return
    fanout = PgFanout(hub, conninfo)
    hub.attach_relay(fanout)
    async with _tasks(fanout.run()):
        yield fanout
    hub.attach_relay(None)
