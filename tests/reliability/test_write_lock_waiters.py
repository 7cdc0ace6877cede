"""Requests waiting for the database's write lock can never hold up the request that has it.

The server runs sync endpoints in a pool of request threads. A request blocked on the write
lock (SQLite's ``BEGIN IMMEDIATE``, a PostgreSQL row lock) holds a thread while it waits; the
request holding the lock must reach its commit without needing another thread, or every
thread waits for a lock whose holder waits for a thread until the busy timeout (seen in
bench/server_bench.py: 50 phones on SQLite, a burst took 30 s and failed with "database is
locked"). The endpoint's response model used to be validated in the thread pool after the
endpoint returned and before the commit (no longer: chameleons.backend.routing).

Here: two request threads; the lock is held from outside while three phones submit their
consent, until both threads are blocked on it and the third request waits for a thread
(read from the server's thread limiter: waiting on the event, not on time); then it is
released. Every phone must be answered 200 and every consent stored.
"""

from __future__ import annotations

import inspect
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import httpx
import pytest
from fastapi import FastAPI
from fastapi.routing import APIRoute
from sqlalchemy import Engine, func, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.app import create_app
from chameleons.backend.models import Session as SessionRow
from chameleons.settings import Settings
from tests.support.bots import ParticipantBot, WizardBot, staff_api, study_with_plan
from tests.support.live_server import LiveServer

PHONES = 3
THREADS = 2
WAIT_S = 120.0  # only a broken server takes long; a loaded machine is slow, never wrong


@pytest.fixture
def small_app(settings: Settings) -> Iterator[FastAPI]:
    application = create_app(settings.model_copy(update={"request_threads": THREADS}))
    yield application
    application.state.engine.dispose()


@contextmanager
def write_lock_held(engine: Engine, session_ids: list[int]) -> Iterator[None]:
    """The lock those submissions need, taken by another connection of the same database."""
    with engine.connect() as connection:
        driver = connection.connection.driver_connection
        assert driver is not None
        if engine.dialect.name == "sqlite":
            driver.execute("BEGIN IMMEDIATE")
        else:
            connection.execute(
                select(SessionRow.id).where(SessionRow.id.in_(session_ids)).with_for_update()
            )
        try:
            yield
        finally:
            if engine.dialect.name == "sqlite":
                driver.execute("ROLLBACK")
            else:
                connection.rollback()


def wait_until(condition: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + WAIT_S
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting until {what}")
        time.sleep(0.01)


def test_lock_waiters_holding_every_thread_do_not_stall_the_lock_holder(
    small_app: FastAPI, engine: Engine
) -> None:
    with LiveServer(small_app) as server, httpx.Client(base_url=server.url, timeout=WAIT_S) as http:
        pi = staff_api(http, engine, "pi")
        study_id = study_with_plan(pi)
        wizards = [WizardBot.create(pi, study_id) for _ in range(PHONES)]
        limiter = small_app.state.request_limiter
        assert limiter.total_tokens == THREADS
        results: list[int] = []

        def consent(token: str) -> None:
            with httpx.Client(base_url=server.url, timeout=WAIT_S) as own:
                try:
                    ParticipantBot(own, token).consent(True)
                    results.append(200)
                except Exception as exc:  # the status goes into the assertion below
                    results.append(getattr(exc, "status", -1))

        phones = [threading.Thread(target=consent, args=(w.token,)) for w in wizards]
        with write_lock_held(engine, [w.session_id for w in wizards]):
            for phone in phones:
                phone.start()
            wait_until(
                lambda: (
                    limiter.statistics().borrowed_tokens == THREADS
                    and limiter.statistics().tasks_waiting >= 1
                ),
                "both request threads wait for the lock and a third request for a thread",
            )
        for phone in phones:
            phone.join(timeout=WAIT_S * 2)
        assert results == [200] * PHONES
        with DbSession(engine) as db:
            ids = [w.session_id for w in wizards]
            stored = db.scalar(
                select(func.count()).where(
                    SessionRow.id.in_(ids), SessionRow.consent_at.is_not(None)
                )
            )
        assert stored == PHONES


def test_every_route_of_the_app_is_threaded(app: FastAPI, database_url: str) -> None:
    """A router made with plain ``APIRouter`` would bring the stall back for its routes."""
    routes = [r for r in app.routes if isinstance(r, APIRoute)]
    assert routes
    # A sync endpoint is only safe through ThreadedRoute's wrapper; async ones are as they are.
    plain_sync = [
        r.path
        for r in routes
        if not (inspect.iscoroutinefunction(r.endpoint) or inspect.isgeneratorfunction(r.endpoint))
    ]
    assert plain_sync == []
