"""A request's write session ends in the endpoint's own thread: committed as soon as the
endpoint returns, rolled back when it raises (chameleons.backend.routing). A SQLite writer
holds the database's write lock until its commit; the commit used to wait for the event loop
to hand it to another thread, while every other writer waited for that lock."""

from __future__ import annotations

import asyncio
import threading

import pytest
from sqlalchemy import Engine, func, select
from sqlalchemy import event as sa_event
from sqlalchemy.orm import Session

from chameleons.backend.db import build_sessionmaker, end_with_endpoint
from chameleons.backend.models import Event
from chameleons.backend.routing import in_thread


def _events(engine: Engine, kind: str) -> int:
    with Session(engine) as other:  # another connection: sees only what was committed
        return int(other.scalar(select(func.count()).where(Event.kind == kind)) or 0)


def _write_session(engine: Engine) -> Session:
    db = build_sessionmaker(engine)()
    end_with_endpoint(db)
    return db


def test_the_endpoint_thread_commits_before_the_wrapper_returns(engine: Engine) -> None:
    ran_in: list[int] = []
    committed_in: list[int] = []

    def endpoint(db: Session) -> str:
        ran_in.append(threading.get_ident())
        db.add(Event(kind="test.committed", source="test"))
        db.flush()
        return "done"

    db = _write_session(engine)
    sa_event.listen(db, "after_commit", lambda _s: committed_in.append(threading.get_ident()))
    try:
        assert asyncio.run(in_thread(endpoint)(db=db)) == "done"
        assert not db.in_transaction()  # nothing left for the dependency's exit
        assert _events(engine, "test.committed") == 1
        assert committed_in == ran_in  # once, in the endpoint's thread
        assert ran_in[0] != threading.get_ident()  # and that was a worker thread
    finally:
        db.close()


def test_an_endpoint_that_raises_leaves_nothing(engine: Engine) -> None:
    def endpoint(db: Session) -> str:
        db.add(Event(kind="test.refused", source="test"))
        db.flush()
        raise ValueError("refused")

    db = _write_session(engine)
    try:
        with pytest.raises(ValueError, match="refused"):
            asyncio.run(in_thread(endpoint)(db=db))
        assert not db.in_transaction()  # rolled back in its thread: the lock is free
        assert _events(engine, "test.refused") == 0
    finally:
        db.close()


def test_a_session_not_marked_as_the_requests_writer_is_left_to_its_owner(
    engine: Engine,
) -> None:
    def endpoint(db: Session) -> None:
        db.add(Event(kind="test.left", source="test"))
        db.flush()

    db = build_sessionmaker(engine)()  # a read session (DbSession): its dependency ends it
    try:
        asyncio.run(in_thread(endpoint)(db=db))
        assert db.in_transaction()
        assert _events(engine, "test.left") == 0
        db.rollback()
    finally:
        db.close()
