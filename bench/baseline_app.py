"""The server benchmark's baseline: a bare FastAPI + SQLAlchemy app doing the same writes and
pushes for the same traffic, and nothing else.

``POST /api/submit/{channel}`` stores the submission and an event row in one transaction
(in the thread pool, as the real server's endpoints run), reads back the channel's state
(its event count and newest events, the shape of the console's state) and pushes two
messages to every WebSocket on ``/ws/{channel}``: ``{"type": "event", "client_id": ...}``
then ``{"type": "console", ...}``, as the real server pushes a submission's event and then
the console's state. The database is ``BENCH_BASELINE_DATABASE_URL`` (a SQLite file or a
PostgreSQL database of its own; tables made at start-up); without it the endpoint only
pushes. The WebSocket ``/echo`` returns each text message at once (the bare round trip of
``bench.speech_bench``). Run by the benchmarks as its own uvicorn process, exactly as the
real server is.
"""

from __future__ import annotations

import asyncio
import os
from collections import defaultdict
from datetime import UTC, datetime
from typing import Any

from fastapi import FastAPI, WebSocket, WebSocketDisconnect
from pydantic import BaseModel
from sqlalchemy import JSON, DateTime, Engine, String, create_engine, event, func, select
from sqlalchemy.engine import make_url
from sqlalchemy.orm import DeclarativeBase, Mapped, Session, mapped_column
from starlette.concurrency import run_in_threadpool

app = FastAPI()
_listeners: defaultdict[str, set[asyncio.Queue[dict[str, Any]]]] = defaultdict(set)
NEWEST = 5  # events the pushed state carries


class Base(DeclarativeBase):
    pass


class Answer(Base):
    __tablename__ = "answer"
    id: Mapped[int] = mapped_column(primary_key=True)
    channel: Mapped[str] = mapped_column(String(64), index=True)
    client_id: Mapped[str] = mapped_column(String(64))
    payload: Mapped[dict[str, Any]] = mapped_column(JSON)


class Event(Base):
    __tablename__ = "event"
    id: Mapped[int] = mapped_column(primary_key=True)
    channel: Mapped[str] = mapped_column(String(64), index=True)
    kind: Mapped[str] = mapped_column(String(32))
    client_id: Mapped[str] = mapped_column(String(64))
    at: Mapped[datetime] = mapped_column(DateTime(timezone=True))


def _engine(url: str) -> Engine:
    parsed = make_url(url)
    if parsed.get_backend_name() == "sqlite":
        found = create_engine(url, connect_args={"check_same_thread": False, "timeout": 30},
                              pool_size=40, max_overflow=0)  # fmt: skip

        def pragmas(connection: Any, _record: Any) -> None:
            connection.execute("PRAGMA journal_mode=WAL")
            connection.execute("PRAGMA synchronous=NORMAL")

        event.listen(found, "connect", pragmas)
    else:
        if parsed.drivername == "postgresql":
            url = parsed.set(drivername="postgresql+psycopg").render_as_string(False)
        found = create_engine(url, pool_size=5, max_overflow=35)
    Base.metadata.create_all(found)
    return found


_URL = os.environ.get("BENCH_BASELINE_DATABASE_URL")
ENGINE = _engine(_URL) if _URL else None


class Submission(BaseModel):
    client_id: str
    answers: dict[str, Any] = {}


def _store(engine: Engine, channel: str, body: Submission) -> dict[str, Any]:
    """The submission and its event in one transaction, then the channel's state."""
    with Session(engine) as db, db.begin():
        db.add(Answer(channel=channel, client_id=body.client_id, payload=body.answers))
        db.add(Event(channel=channel, kind="submitted", client_id=body.client_id,
                     at=datetime.now(UTC)))  # fmt: skip
    with Session(engine) as db:
        count = db.scalar(select(func.count()).where(Event.channel == channel))
        newest = db.scalars(select(Event).where(Event.channel == channel)
                            .order_by(Event.id.desc()).limit(NEWEST))  # fmt: skip
        shown = [{"id": e.id, "kind": e.kind, "client_id": e.client_id,
                  "at": e.at.isoformat()} for e in newest]  # fmt: skip
    return {"type": "console", "count": count, "events": shown}


@app.post("/api/submit/{channel}")
async def submit(channel: str, body: Submission) -> dict[str, bool]:
    state = None
    if ENGINE is not None:
        state = await run_in_threadpool(_store, ENGINE, channel, body)
    for queue in _listeners[channel]:
        queue.put_nowait({"type": "event", "client_id": body.client_id})
        if state is not None:
            queue.put_nowait(state)
    return {"ok": True}


@app.get("/healthz")
async def healthz() -> dict[str, str]:
    return {"status": "ok"}


@app.websocket("/ws/{channel}")
async def listen(websocket: WebSocket, channel: str) -> None:
    """Pushes the channel's messages; reads (and ignores) what the client sends, which is
    how it learns at once that the client left (the real server does the same)."""
    await websocket.accept()
    queue: asyncio.Queue[dict[str, Any]] = asyncio.Queue()
    _listeners[channel].add(queue)

    async def push() -> None:
        while True:
            await websocket.send_json(await queue.get())

    pushing = asyncio.create_task(push())
    try:
        while True:
            await websocket.receive_text()
    except WebSocketDisconnect:
        pass
    finally:
        pushing.cancel()
        _listeners[channel].discard(queue)


@app.websocket("/echo")
async def echo(websocket: WebSocket) -> None:
    await websocket.accept()
    try:
        while True:
            await websocket.send_text(await websocket.receive_text())
    except WebSocketDisconnect:
        pass
