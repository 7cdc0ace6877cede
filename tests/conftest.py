"""Shared fixtures: real databases built by the migrations, the app, a live server, a browser.

Databases: every test that asks for ``database_url`` runs on SQLite, and on PostgreSQL too
when ``TEST_DATABASE_URL`` is set (CI sets it). Each SQLite test gets a copy of a database
migrated once per run; each PostgreSQL test gets a per-xdist-worker database migrated once
and emptied after the test.
"""

from __future__ import annotations

import os
import secrets
import shutil
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import Engine, text
from sqlalchemy.engine import make_url

from chameleons.backend.app import create_app
from chameleons.backend.db import build_engine, build_sessionmaker
from chameleons.backend.migrate import upgrade
from chameleons.backend.models import Base
from chameleons.settings import Settings
from tests.support.live_server import LiveServer

pytest_plugins = ["tests.support.browser", "tests.support.catalogues"]

BACKENDS = ["sqlite", "postgres"]


@pytest.fixture(scope="session")
def sqlite_template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("template") / "template.sqlite3"
    upgrade(f"sqlite:///{path}")
    return path


@pytest.fixture(scope="session")
def postgres_url(worker_id: str) -> Iterator[str]:
    """A database of this xdist worker's own on the TEST_DATABASE_URL server, migrated."""
    base = os.environ.get("TEST_DATABASE_URL")
    if not base:
        if os.environ.get("CHAMELEONS_REQUIRE_POSTGRES_TESTS"):
            pytest.fail("CHAMELEONS_REQUIRE_POSTGRES_TESTS is set but TEST_DATABASE_URL is not")
        pytest.skip("TEST_DATABASE_URL is not set: PostgreSQL tests skipped")
    url = make_url(base).set(drivername="postgresql+psycopg")
    # Unique per run, so two test runs against one server never drop each other's database.
    name = f"{url.database}_{worker_id}_{secrets.token_hex(3)}"
    admin = build_engine(url.render_as_string(hide_password=False))
    with admin.connect().execution_options(isolation_level="AUTOCOMMIT") as conn:
        conn.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        conn.execute(text(f'CREATE DATABASE "{name}"'))
    worker_url = url.set(database=name).render_as_string(hide_password=False)
    upgrade(worker_url)
    yield worker_url
    with admin.connect().execution_options(isolation_level="AUTOCOMMIT") as conn:
        conn.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
    admin.dispose()


def _truncate_all(url: str) -> None:
    engine = build_engine(url)
    tables = ", ".join(f'"{t.name}"' for t in Base.metadata.sorted_tables)
    with engine.begin() as conn:
        conn.execute(text(f"TRUNCATE {tables} RESTART IDENTITY CASCADE"))
    engine.dispose()


@pytest.fixture(params=BACKENDS)
def database_url(
    request: pytest.FixtureRequest, tmp_path: Path, sqlite_template: Path
) -> Iterator[str]:
    if request.param == "sqlite":
        path = tmp_path / "test.sqlite3"
        shutil.copyfile(sqlite_template, path)
        yield f"sqlite:///{path}"
        return
    url: str = request.getfixturevalue("postgres_url")
    yield url
    _truncate_all(url)


@pytest.fixture
def engine(database_url: str) -> Iterator[Engine]:
    eng = build_engine(database_url)
    yield eng
    eng.dispose()


@pytest.fixture
def db_session(engine: Engine) -> Iterator[object]:
    session = build_sessionmaker(engine)()
    yield session
    session.rollback()
    session.close()


@pytest.fixture
def settings(database_url: str, tmp_path: Path) -> Settings:
    return Settings(
        database_url=database_url,
        data_dir=tmp_path / "data",
        secret_key=secrets.token_urlsafe(32),
        login_max_failures=3,
        login_lockout_seconds=60,
        bridge_enabled=False,  # tests that need a worker start their own bridge
        _env_file=None,
    )


@pytest.fixture
def app(settings: Settings) -> Iterator[FastAPI]:
    application = create_app(settings)
    yield application
    # A test that never ran the app's lifespan (no TestClient context) would leave the
    # engine's pooled connections to the garbage collector: a ResourceWarning in a later test.
    application.state.engine.dispose()


@pytest.fixture
def client(app: FastAPI) -> Iterator[TestClient]:
    with TestClient(app) as test_client:
        yield test_client


@pytest.fixture
def live_server(app: FastAPI) -> Iterator[LiveServer]:
    server = LiveServer(app)
    server.start()
    yield server
    server.stop()


BROWSER_FIXTURES = {
    "playwright_instance",
    "browser",
    "context",
    "page",
    "phone_context",
    "screen_context",
}


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Every test that drives Chromium is marked ``browser``: Playwright's sync API keeps an
    asyncio loop running in the main thread for the rest of the process, so `make test`
    runs browser tests in a pytest run of their own (``-m browser``). A run that selects
    both (a plain ``pytest``, as on a Windows lab PC) runs the browser tests last: a test
    that calls ``asyncio.run`` after one of them in the same process fails ("cannot be
    called from a running event loop"). Stable, so the order within each kind stays."""
    for item in items:
        if BROWSER_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.browser)
    items.sort(key=lambda item: item.get_closest_marker("browser") is not None)
