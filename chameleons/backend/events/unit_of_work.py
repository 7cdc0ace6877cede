"""The write transaction of a request, committed before the response is sent.

The shared ``DbSession`` dependency commits after the response has gone out, so a client
could read stale state right after a "saved" answer (or be told "saved" for a commit that
then fails). Writes that a client acts on use ``WriteDb`` instead: its exit runs before
the response. After the commit, the events recorded in the transaction go to the live hub.
"""

from __future__ import annotations

import threading
from collections.abc import AsyncIterator, Iterator
from contextlib import AbstractContextManager, contextmanager
from typing import Annotated, Any

import anyio
import anyio.to_thread
from fastapi import Depends, Request
from sqlalchemy import event as sa_event
from sqlalchemy.orm import Session, sessionmaker

from chameleons.backend.db import end_with_endpoint
from chameleons.backend.events.hub import RESYNC, LiveHub, session_channel
from chameleons.backend.events.repository import (
    GONE,
    GONE_KEY,
    HUB_KEY,
    KEEP_KEY,
    NOTICES_KEY,
    OUTBOX_KEY,
    RESYNC_KEY,
    RETAIN_KEY,
    to_dict,
)
from chameleons.backend.models import Event


def get_hub(request: Request) -> LiveHub:
    hub: LiveHub = request.app.state.live_hub
    return hub


_listening = threading.Lock()
_listens = False


def attach_hub(db: Session, hub: LiveHub) -> None:
    """Publish the events recorded in ``db`` after each commit; forget them on rollback.

    The listeners are the ``Session`` class's, installed once per process: listeners of a
    session's own make SQLAlchemy build a dispatcher for that session, which took 1.5-2.5 %
    of the server's CPU samples in bench/server_bench.py (docs/performance.md). Sessions
    without a hub are left alone."""
    _listen_once()
    db.info[HUB_KEY] = hub


def _listen_once() -> None:
    global _listens
    if _listens:
        return
    with _listening:
        if not _listens:
            sa_event.listen(Session, "after_commit", _after_commit)
            sa_event.listen(Session, "after_rollback", _after_rollback)
            _listens = True


def _after_commit(session: Session) -> None:
    hub: LiveHub | None = session.info.get(HUB_KEY)
    if hub is None:
        return
    for store, key, value in session.info.pop(KEEP_KEY, []):
        store[key] = value
    # Retained first: a reader woken by the events below finds the state they made.
    for channel, value in session.info.pop(RETAIN_KEY, {}).items():
        hub.retain(channel, value)
    published: list[Event] = session.info.pop(OUTBOX_KEY, [])
    # In one turn of the loop: a console gets the commit's events as one batch (issue 34).
    hub.publish_all([(session_channel(event.session_id), {"type": "event", "event": to_dict(event)})
                     for event in published if event.session_id is not None])  # fmt: skip
    for session_id in session.info.pop(RESYNC_KEY, []):
        hub.forget(session_channel(session_id))
        hub.publish(session_channel(session_id), RESYNC)
    for session_id in session.info.pop(GONE_KEY, []):
        hub.forget(session_channel(session_id))
        hub.publish(session_channel(session_id), GONE)
    for channel, message in session.info.pop(NOTICES_KEY, []):
        hub.publish(channel, message)


def _after_rollback(session: Session) -> None:
    if HUB_KEY not in session.info:
        return
    for key in (OUTBOX_KEY, GONE_KEY, RESYNC_KEY, RETAIN_KEY, NOTICES_KEY, KEEP_KEY):
        session.info.pop(key, None)


def write_scope(factory: sessionmaker[Session], hub: LiveHub) -> Iterator[Session]:
    db = factory()
    attach_hub(db, hub)
    try:
        yield db
        db.commit()
    except BaseException:
        db.rollback()
        raise
    finally:
        db.close()


def write_session(factory: sessionmaker[Session], hub: LiveHub) -> AbstractContextManager[Session]:
    """``with write_session(factory, hub) as db:`` outside requests (WebSockets, scripts)."""
    return contextmanager(write_scope)(factory, hub)


async def get_write_db(request: Request) -> AsyncIterator[Session]:
    """The request's session; it commits (or rolls back) on a thread of its own pool.

    A request that holds a write lock (SQLite's, taken by ``BEGIN IMMEDIATE``, or a
    PostgreSQL row lock) must be able to commit while every request thread waits for that
    lock. Committing in a sync dependency's exit needs a thread of the shared pool, which
    those waiting requests hold: each waited out the lock's timeout (bench/server_bench.py:
    a burst of 50 phones on SQLite took 30 s and failed). Creating the session does no I/O,
    so it happens here in the event loop."""
    db = request.app.state.sessionmaker()
    attach_hub(db, get_hub(request))
    end_with_endpoint(db)  # committed in the endpoint's thread (routing.in_thread)
    ending = _ending_limiter(request.app.state)
    try:
        yield db
        if db.in_transaction():  # a sync endpoint's was committed in its thread already
            await anyio.to_thread.run_sync(db.commit, limiter=ending)
    except BaseException:
        if db.in_transaction():
            await anyio.to_thread.run_sync(db.rollback, limiter=ending)
        raise
    finally:
        if db.in_transaction():
            await anyio.to_thread.run_sync(db.close, limiter=ending)
        else:
            db.close()  # holds no connection: nothing to wait for


ENDING_THREADS = 8


def _ending_limiter(state: Any) -> anyio.CapacityLimiter:
    """The commit/rollback threads, made on first use (a limiter needs the running loop)."""
    limiter: anyio.CapacityLimiter | None = getattr(state, "ending_limiter", None)
    if limiter is None:
        limiter = state.ending_limiter = anyio.CapacityLimiter(ENDING_THREADS)
    return limiter


WriteDb = Annotated[Session, Depends(get_write_db, scope="function")]
Hub = Annotated[LiveHub, Depends(get_hub)]
