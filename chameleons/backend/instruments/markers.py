"""The server's LSL ``Markers`` streams (``CHAMELEONS_LSL=1``, docs/instruments.md): every
timeline event of a booth's session, once committed, as one marker on
``chameleons-<booth>-events`` (:func:`chameleons.instruments.lsl.marker_text`), stamped with
the event's server time on LSL's clock.

A listener of the live hub queues each committed event; one thread of its own finds the
session's booth (a database read, remembered), opens the booth's outlet when it has none and
pushes the marker, so neither a request nor the event loop ever waits for LSL. Outlets are
opened at start for every booth the database knows (and the configured worker booth), and
for a booth whose worker connects, so a lab's LabRecorder sees the streams before the first
session starts.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
from collections.abc import AsyncIterator, Iterable
from datetime import UTC, datetime
from typing import Any

from fastapi import FastAPI
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession
from sqlalchemy.orm import sessionmaker

from chameleons.backend.events.hub import LiveHub, Message
from chameleons.backend.models import Session
from chameleons.instruments.lsl import LslClock, marker_text, markers_outlet, require_pylsl

log = logging.getLogger(__name__)
SESSION_PREFIX = "session:"
_STOP = object()


class MarkerPublisher:
    """Pushes committed timeline events to their booth's ``Markers`` outlet."""

    def __init__(self, factory: sessionmaker[DbSession]) -> None:
        self.factory = factory
        self.clock = LslClock()
        self.outlets: dict[str, Any] = {}
        self.booths: dict[int, str] = {}
        self.pushed = 0
        self._queue: queue.SimpleQueue[object] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None

    def open(self, booths: Iterable[str]) -> None:
        for booth in booths:
            self._outlet(booth)

    def _outlet(self, booth: str) -> Any:
        outlet = self.outlets.get(booth)
        if outlet is None:
            outlet = self.outlets[booth] = markers_outlet(booth, f"chameleons-{booth}-events")
            log.info("LSL markers stream chameleons-%s-events opened", booth)
        return outlet

    def on_worker(self, message: Any) -> None:
        """The bridge's ``worker.<booth>`` news: a booth's worker (re)connected, so its
        markers stream is open before its first session (a bridge listener)."""
        booth = str(getattr(message, "topic", "")).partition(".")[2]
        if booth:
            self._queue.put(("open", booth))

    def on_message(self, channel: str, message: Message) -> None:
        """The hub listener: queue committed events (on the loop; returns at once)."""
        if channel.startswith(SESSION_PREFIX) and message.get("type") == "event":
            self._queue.put(message["event"])

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="lsl-markers", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        self._queue.put(_STOP)
        if self._thread is not None:
            self._thread.join(timeout)
        self.outlets = {}

    def _run(self) -> None:
        while (item := self._queue.get()) is not _STOP:
            try:
                if isinstance(item, tuple):
                    self._outlet(item[1])
                else:
                    self.push(item)  # type: ignore[arg-type]
            except Exception:  # one bad event never ends the markers of the rest
                log.exception("LSL marker not sent")

    def push(self, event: dict[str, Any]) -> None:
        session_id = event.get("session_id")
        if session_id is None:
            return
        booth = self._booth(int(session_id))
        if booth is None:
            return
        stamp = self.clock.from_wall(_epoch(event.get("server_time")))
        self._outlet(booth).push_sample([marker_text(event)], stamp)
        self.pushed += 1

    def _booth(self, session_id: int) -> str | None:
        booth = self.booths.get(session_id)
        if booth is None:
            with self.factory() as db:
                booth = db.scalar(select(Session.booth).where(Session.id == session_id))
            if booth is not None:
                self.booths[session_id] = booth
        return booth


def _epoch(iso: Any) -> float:
    if not iso:
        return datetime.now(UTC).timestamp()
    moment = datetime.fromisoformat(str(iso))
    return (moment if moment.tzinfo else moment.replace(tzinfo=UTC)).timestamp()


def known_booths(factory: sessionmaker[DbSession]) -> list[str]:
    with factory() as db:
        return sorted(set(db.scalars(select(Session.booth).distinct())))


@contextlib.asynccontextmanager
async def publishing(app: FastAPI) -> AsyncIterator[MarkerPublisher]:
    """While the server runs: the booths' markers streams (the lifespan enters this when
    ``settings.lsl`` is on)."""
    import anyio.to_thread

    require_pylsl()
    settings = app.state.settings
    hub: LiveHub = app.state.live_hub
    publisher = MarkerPublisher(app.state.sessionmaker)
    booths = await anyio.to_thread.run_sync(known_booths, app.state.sessionmaker)
    await anyio.to_thread.run_sync(publisher.open, [*booths, settings.worker_booth])
    publisher.start()
    remove = hub.add_listener(publisher.on_message)
    if app.state.bridge is not None:  # a booth whose worker connects gets its stream then
        app.state.bridge.add_listener("worker.", publisher.on_worker)
    app.state.lsl_markers = publisher
    try:
        yield publisher
    finally:
        remove()
        await anyio.to_thread.run_sync(publisher.stop)
        app.state.lsl_markers = None
