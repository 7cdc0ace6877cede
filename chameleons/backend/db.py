"""Engine and session factory. The request's session dependency is the one place that commits."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session, sessionmaker

from chameleons.backend import write_gate

# How long a SQLite writer waits for the write lock before "database is locked". Writers
# queue one at a time (BEGIN IMMEDIATE); 50 phones submitting at once on a loaded 2-core
# machine needed more than the 5 s this was (bench/server_bench.py: 33 of 50 burst
# submissions failed); a lab's request never waits that long unless the disk stalls.
SQLITE_BUSY_TIMEOUT_S = 30


def _sqlite_pragmas(dbapi_connection: Any, _record: Any) -> None:
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA foreign_keys=ON")
    # Deleted rows (a withdrawal) are overwritten with zeros, not left in free pages.
    cursor.execute("PRAGMA secure_delete=ON")
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_TIMEOUT_S * 1000}")
    cursor.execute("PRAGMA synchronous=NORMAL")
    cursor.close()


# Connections the pool may hand out at once. The server runs at most this many request
# threads (``request_threads``): a request takes its connection in one threadpool call (the
# session dependency) and runs its endpoint in another, so with fewer connections than
# threads, threads waiting for a connection could hold every thread token while the
# requests holding the connections wait for a token (idle in transaction until the pool's
# timeout: seen with 15 connections and 40 threads at 50 phones on PostgreSQL).
# PostgreSQL: five kept open when idle (SQLAlchemy's default), the rest opened under load
# and closed when returned. SQLite keeps all of them (``SQLITE_POOL``): a connection is a
# file handle, and each new one ran its PRAGMAs again (about 6 % of a busy server's CPU,
# issue 34: the overflow connections were opened and closed with every burst).
POOL_SIZE = 5
POOL_OVERFLOW = 35
SQLITE_POOL = {"pool_size": POOL_SIZE + POOL_OVERFLOW, "max_overflow": 0}


def write_transaction(db: Session) -> None:
    """Make ``db``'s transaction a writer now, before it reads the state it will change.

    PostgreSQL serialises such changes with the row lock of ``SELECT ... FOR UPDATE``; on
    SQLite that clause does nothing, so two requests could both read "pending" and both
    decide. There the transaction takes the database's write lock first (``BEGIN
    IMMEDIATE``; a second writer waits up to the busy timeout) and then reads what the
    previous writer committed. Reads before this point ran outside a transaction (the
    driver begins one only before a write), and a transaction that has written already
    holds the lock."""
    if db.get_bind().dialect.name != "sqlite":
        return
    connection = db.connection()
    driver = connection.connection.driver_connection
    if driver is not None and not driver.in_transaction:
        write_gate.enter(connection, SQLITE_BUSY_TIMEOUT_S)
        connection.exec_driver_sql("BEGIN IMMEDIATE")


_ENDS_WITH_ENDPOINT = "chameleons_ends_with_endpoint"


def end_with_endpoint(db: Session) -> None:
    """Mark ``db`` as a request's write session: it commits (or rolls back) in the endpoint's
    own thread as soon as the endpoint returns (``routing.in_thread``)."""
    db.info[_ENDS_WITH_ENDPOINT] = True


def ends_with_endpoint(value: object) -> bool:
    return isinstance(value, Session) and bool(value.info.get(_ENDS_WITH_ENDPOINT))


def build_engine(url: str) -> Engine:
    """Create an engine; for SQLite make the directory and set WAL, foreign keys, timeout.

    ``hide_parameters``: a database error in the log shows the SQL but not its bound values,
    which may be a participant's free text (docs/security.md: free text is never logged)."""
    parsed = make_url(url)
    pool = {"pool_size": POOL_SIZE, "max_overflow": POOL_OVERFLOW}
    if parsed.get_backend_name() == "sqlite":
        memory = not parsed.database or parsed.database == ":memory:"
        if not memory:
            Path(parsed.database or "").parent.mkdir(parents=True, exist_ok=True)
        engine = create_engine(url, connect_args={"check_same_thread": False,
                                                  "timeout": SQLITE_BUSY_TIMEOUT_S},
                               hide_parameters=True,
                               **({} if memory else SQLITE_POOL))  # fmt: skip
        event.listen(engine, "connect", _sqlite_pragmas)
        write_gate.install(engine)
        return engine
    if parsed.get_backend_name() == "postgresql" and parsed.drivername == "postgresql":
        url = parsed.set(drivername="postgresql+psycopg").render_as_string(hide_password=False)
    return create_engine(url, pool_pre_ping=True, hide_parameters=True, **pool)


def request_threads(engine: Engine) -> int:
    """How many request threads the server may run: no more than the pool's connections."""
    pool = engine.pool
    size = getattr(pool, "size", None)
    overflow = getattr(pool, "_max_overflow", None)
    if callable(size) and isinstance(overflow, int) and overflow >= 0:
        return int(size()) + overflow
    return POOL_SIZE + POOL_OVERFLOW


_READ_ONLY = "chameleons_read_only"


def is_read_only(db: Session) -> bool:
    """``db`` came from ``build_read_sessionmaker``: nothing in it can change."""
    return bool(db.info.get(_READ_ONLY))


def build_sessionmaker(engine: Engine) -> sessionmaker[Session]:
    return sessionmaker(bind=engine, expire_on_commit=False)


class ReadOnlySessionError(RuntimeError):
    """A change was made in a session meant only to read."""


def build_read_sessionmaker(engine: Engine) -> sessionmaker[Session]:
    """Sessions that only read (the staff check of every staff request, the console's state
    after every change). On PostgreSQL they run in autocommit: each statement sees the newest
    committed data, as it does inside a READ COMMITTED transaction, without the BEGIN and
    ROLLBACK round trips around them (docs/performance.md). SQLite keeps its transaction
    (one snapshot for the whole read; it has no round trips to save). A flush or a write
    statement in them raises: in autocommit it would be kept."""
    postgres = engine.dialect.name == "postgresql"
    bind = engine.execution_options(isolation_level="AUTOCOMMIT") if postgres else engine
    factory = sessionmaker(bind=bind, expire_on_commit=False, info={_READ_ONLY: True})
    event.listen(factory, "before_flush", _refuse_flush)
    event.listen(factory, "do_orm_execute", _refuse_write)
    return factory


def _refuse_flush(session: Session, _context: Any, _instances: Any) -> None:
    if session.new or session.dirty or session.deleted:
        raise ReadOnlySessionError("a read-only session was asked to store a change")


def _refuse_write(state: Any) -> None:
    if not state.is_select:
        raise ReadOnlySessionError("a read-only session was asked to run a write statement")


@contextmanager
def session_scope(factory: sessionmaker[Session]) -> Iterator[Session]:
    """``with session_scope(factory) as db:`` commits when the block ends normally (also by
    ``return``) and rolls back when it raises."""
    session = factory()
    try:
        yield session
        session.commit()
    except BaseException:
        session.rollback()
        raise
    finally:
        session.close()
