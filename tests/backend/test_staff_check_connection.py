"""The staff check of a request gives its database connection back before the endpoint runs
(chameleons.backend.auth.dependencies.current_staff): the dependency and the endpoint run in
two thread-pool calls, and a request between them holding a connection while waiting for a
thread starved the pool (bench/server_hold.py, 200 phones on SQLite: every phone failed on
the pool's 30 s timeout)."""

from __future__ import annotations

from fastapi import FastAPI
from sqlalchemy import Engine, select
from starlette.requests import Request

from chameleons.backend.auth import sessions
from chameleons.backend.auth.dependencies import current_staff
from chameleons.backend.models import StaffUser
from tests.support.bots import add_staff


def _request(app: FastAPI, key: str) -> Request:
    return Request({"type": "http", "app": app, "session": {sessions.SESSION_KEY: key},
                    "path": "/api/sessions", "headers": [], "query_string": b""})  # fmt: skip


def test_the_staff_check_holds_no_connection_for_the_endpoint(app: FastAPI, engine: Engine) -> None:
    add_staff(engine, "wizard-1", "wizard")
    with app.state.sessionmaker() as setup:
        user = setup.scalars(select(StaffUser).where(StaffUser.username == "wizard-1")).one()
        key = sessions.start(setup, user, hours=1)
        setup.commit()
    db = app.state.sessionmaker()
    try:
        found = current_staff(_request(app, key), db)
        assert (found.username, found.role) == ("wizard-1", "wizard")
        assert found in db  # the request's own object: its endpoint may use it with db
        assert app.state.engine.pool.checkedout() == 0  # and no connection is held for it
    finally:
        db.close()
