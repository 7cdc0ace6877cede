"""Append-only events. ``record`` flushes the row and queues it for live publishing, which
happens only after the transaction commits (see :mod:`.unit_of_work`)."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from sqlalchemy import bindparam, func, select
from sqlalchemy import event as sa_event
from sqlalchemy.engine import Connection
from sqlalchemy.orm import Mapper, ORMExecuteState, Session, SessionTransaction, object_session

from chameleons.backend.db import is_read_only
from chameleons.backend.models import Event
from chameleons.backend.models.base import utcnow

OUTBOX_KEY = "live_outbox"
GONE_KEY = "live_gone_sessions"
RESYNC_KEY = "live_resync_sessions"
RETAIN_KEY = "live_retained"
NOTICES_KEY = "live_notices"  # (channel, message) pairs
KEEP_KEY = "kept_after_commit"  # (store, key, value) triples
HUB_KEY = "live_hub"  # in ``Session.info``: the hub a session publishes to after commits
GONE: dict[str, Any] = {"type": "gone"}


def announce_gone(db: Session, session_ids: list[int]) -> None:
    """After the commit, tell whoever watches these sessions live that they no longer exist
    (a withdrawal deleted them): an open console tab says so instead of going stale."""
    db.info.setdefault(GONE_KEY, []).extend(session_ids)


def retain_after_commit(db: Session, channel: str, view: str, value: dict[str, Any]) -> None:
    """After the commit (never on rollback), keep ``value`` as the channel's latest
    committed state for ``view`` (the console's, the phone's) in the live hub
    (``LiveHub.retain``). The views a commit retains replace all the channel kept before:
    a view this commit did not make is no longer the latest."""
    db.info.setdefault(RETAIN_KEY, {}).setdefault(channel, {})[view] = value


def keep_after_commit(db: Session, store: dict[Any, Any], key: Any, value: Any) -> None:
    """After the commit (never on rollback), ``store[key] = value``: a process cache of
    facts that hold once committed (sessions.snapshot's settled suggestions). Only sessions
    with a live hub are committed through the listener that does it (``unit_of_work``);
    in others nothing is kept, which a cache can afford."""
    if HUB_KEY in db.info:
        db.info.setdefault(KEEP_KEY, []).append((store, key, value))


def keep_once_committed(
    db: Session, store: dict[Any, Any], key: Any, value: Any, limit: int = 4096
) -> None:
    """``store[key] = value`` once ``db``'s state is committed: at once if ``db`` is read
    only (what it reads is committed), else after the commit (``keep_after_commit``). A
    store of ``limit`` entries is emptied first: the caches this serves hold a server's
    sessions x interactions, and an emptied one reads from the database again."""
    if len(store) >= limit:
        store.clear()
    if is_read_only(db):
        store[key] = value
    else:
        keep_after_commit(db, store, key, value)


def announce_rewritten(db: Session, session_ids: set[int]) -> None:
    """After the commit, tell live watchers of these sessions that events they were sent
    have changed (a withdrawal emptied the ones quoting the withdrawn participant): they
    read the whole timeline again instead of keeping the old texts."""
    db.info.setdefault(RESYNC_KEY, []).extend(sorted(session_ids))


def publish_after_commit(db: Session, channel: str, message: dict[str, Any]) -> None:
    """Publish ``message`` on the live hub's ``channel`` once the transaction commits (and
    through it to the other server processes); a rollback drops it."""
    db.info.setdefault(NOTICES_KEY, []).append((channel, message))


def pending_notices(db: Session) -> list[tuple[str, dict[str, Any]]]:
    """What ``publish_after_commit`` queued in this transaction so far."""
    return list(db.info.get(NOTICES_KEY, []))


def record(
    db: Session,
    kind: str,
    *,
    source: str,
    study_id: int | None = None,
    session_id: int | None = None,
    interaction_id: int | None = None,
    payload: dict[str, Any] | None = None,
    worker_time: float | None = None,
    client_id: str | None = None,
    at: datetime | None = None,
) -> Event:
    event = Event(
        kind=kind,
        source=source,
        study_id=study_id,
        session_id=session_id,
        interaction_id=interaction_id,
        payload=payload or {},
        worker_time=worker_time,
        client_id=client_id,
        server_time=at or utcnow(),
    )
    db.add(event)
    db.flush()
    db.info.setdefault(OUTBOX_KEY, []).append(event)
    return event


# Built once (see sessions.flow.SUGGESTIONS_OF_INTERACTIONS): every submission asks both.
BY_CLIENT_ID = select(Event).where(
    Event.session_id == bindparam("session_id"), Event.client_id == bindparam("client_id")
)
NEWEST_ID = select(func.max(Event.id)).where(Event.session_id == bindparam("session_id"))


def find_by_client_id(db: Session, session_id: int, client_id: str) -> Event | None:
    found = db.scalars(BY_CLIENT_ID, {"session_id": session_id, "client_id": client_id})
    return found.first()


def for_session(db: Session, session_id: int, after_id: int = 0, limit: int = 1000) -> list[Event]:
    query = (
        select(Event)
        .where(Event.session_id == session_id, Event.id > after_id)
        .order_by(Event.id)
        .limit(limit)
    )
    return list(db.scalars(query))


def last_id(db: Session, session_id: int) -> int:
    """The newest event's id: a version number of the session that only grows. On SQLite,
    once this transaction has inserted an event of the session, that is the newest one and
    no statement is needed (``_note_inserted``)."""
    noted: _Noted | None = db.info.get(_INSERTED_KEY)
    if noted is not None and noted[0] is db.get_transaction() and session_id in noted[1]:
        return noted[1][session_id]
    value = db.scalar(NEWEST_ID, {"session_id": session_id})
    return int(value or 0)


# The newest event id each session got in a SQLite transaction, in ``Session.info``: the
# transaction it was noted in, and the ids by session. A SQLite transaction that has
# inserted a row holds the database's write lock until it ends, so no other connection can
# add an event before its commit, and an event's id is above every id the table ever held
# (``AUTOINCREMENT``, models.base.NEVER_REUSED_IDS). So the newest id it inserted for a
# session is that session's newest event, and ``SELECT max(event.id)`` (once per snapshot,
# issue 34) would only read it back. PostgreSQL's writers do not exclude each other (a prompt
# play's event takes no session lock), so there the statement stays. An event inserted in a
# savepoint (which may be rolled back on its own) or deleted makes its session's id unknown
# again: that session is asked.
_INSERTED_KEY = "events_inserted"
_Noted = tuple[SessionTransaction, dict[int, int]]


@sa_event.listens_for(Event, "after_insert")
def _note_inserted(_mapper: Mapper[Event], connection: Connection, target: Event) -> None:
    db = object_session(target)
    if db is None or target.session_id is None or connection.dialect.name != "sqlite":
        return
    transaction = db.get_transaction()
    noted: _Noted | None = db.info.get(_INSERTED_KEY)
    if noted is None or noted[0] is not transaction:
        if transaction is None:
            return
        noted = (transaction, {})
        db.info[_INSERTED_KEY] = noted
    ids = noted[1]
    if db.in_nested_transaction():
        ids.pop(target.session_id, None)
        return
    ids[target.session_id] = max(ids.get(target.session_id, 0), target.id)


@sa_event.listens_for(Event, "after_delete")
def _forget_deleted(_mapper: Mapper[Event], _connection: Connection, target: Event) -> None:
    """A session whose event this transaction deleted is asked again (its newest may be gone)."""
    db = object_session(target)
    noted: _Noted | None = db.info.get(_INSERTED_KEY) if db is not None else None
    if noted is not None and target.session_id is not None:
        noted[1].pop(target.session_id, None)


@sa_event.listens_for(Session, "do_orm_execute")
def _forget_after_bulk(state: ORMExecuteState) -> None:
    """A bulk ``delete()``/``update()`` statement (withdrawal deletes events so) passes no
    single row through the mapper events: every noted id of the transaction is forgotten."""
    if state.is_delete or state.is_update:
        state.session.info.pop(_INSERTED_KEY, None)


def iso(moment: datetime | None) -> str | None:
    """ISO 8601 in UTC; SQLite hands back naive datetimes for timezone-aware columns."""
    if moment is None:
        return None
    return (moment if moment.tzinfo else moment.replace(tzinfo=UTC)).isoformat()


def to_dict(event: Event) -> dict[str, Any]:
    return {
        "id": event.id,
        "kind": event.kind,
        "source": event.source,
        "session_id": event.session_id,
        "interaction_id": event.interaction_id,
        "server_time": iso(event.server_time),
        "worker_time": event.worker_time,
        "client_id": event.client_id,
        "payload": event.payload,
    }
