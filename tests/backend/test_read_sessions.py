"""Read-only sessions (the staff check, the console's state after each change): on PostgreSQL
they read outside a transaction, saving the BEGIN and ROLLBACK round trips around every
read; on either database a change in them is refused, since in autocommit it would be kept
(chameleons.backend.db.build_read_sessionmaker)."""

from __future__ import annotations

import pytest
from psycopg.pq import TransactionStatus
from sqlalchemy import Engine, func, select, update

from chameleons.backend.db import (
    ReadOnlySessionError,
    build_read_sessionmaker,
    build_sessionmaker,
)
from chameleons.backend.models import StaffUser
from tests.backend.test_auth import add_user


def _transaction_status(session: object) -> TransactionStatus:
    connection = session.connection()  # type: ignore[attr-defined]
    return TransactionStatus(connection.connection.dbapi_connection.info.transaction_status)


def test_a_read_on_postgresql_opens_no_transaction(engine: Engine) -> None:
    if engine.dialect.name != "postgresql":
        pytest.skip("SQLite keeps its read transaction (one snapshot, no round trips)")
    with build_read_sessionmaker(engine)() as db:
        assert db.scalar(select(func.count(StaffUser.id))) is not None
        assert _transaction_status(db) == TransactionStatus.IDLE
    with build_sessionmaker(engine)() as db:  # the request's own session, for contrast
        db.scalar(select(func.count(StaffUser.id)))
        assert _transaction_status(db) == TransactionStatus.INTRANS


def test_a_read_session_refuses_changes(engine: Engine) -> None:
    add_user(engine, "reader", "a long password", "wizard")
    factory = build_read_sessionmaker(engine)
    with factory() as db:
        user = db.scalars(select(StaffUser).where(StaffUser.username == "reader")).one()
        user.is_active = False
        with pytest.raises(ReadOnlySessionError):
            db.flush()
        db.rollback()
        with pytest.raises(ReadOnlySessionError):
            db.execute(update(StaffUser).values(is_active=False))
    with build_sessionmaker(engine)() as db:  # nothing was kept
        assert db.scalars(select(StaffUser.is_active).where(StaffUser.username == "reader")).one()
