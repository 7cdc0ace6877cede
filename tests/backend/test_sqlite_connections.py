"""SQLite connections are kept and reused, not opened (and their PRAGMAs run) again with
every burst of requests (issue 34), and a reused connection still has every setting."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import Engine, event

from chameleons.backend.db import POOL_SIZE, SQLITE_BUSY_TIMEOUT_S, build_engine, request_threads

AT_ONCE = POOL_SIZE + 5  # more connections at once than the pool used to keep


@pytest.fixture
def engine(tmp_path: Path) -> Iterator[Engine]:
    found = build_engine(f"sqlite:///{tmp_path / 'pool.sqlite3'}")
    yield found
    found.dispose()


def _opened(engine: Engine) -> list[Any]:
    opened: list[Any] = []
    event.listen(engine, "connect", lambda connection, _record: opened.append(connection))
    return opened


def _burst(engine: Engine) -> list[Any]:
    """``AT_ONCE`` connections checked out together, then all returned: their settings."""
    with ExitStack() as held:
        connections = [held.enter_context(engine.connect()) for _ in range(AT_ONCE)]
        return [_settings(connection) for connection in connections]


def _settings(connection: Any) -> dict[str, Any]:
    return {name: connection.exec_driver_sql(f"PRAGMA {name}").scalar()
            for name in ("foreign_keys", "journal_mode", "busy_timeout", "secure_delete",
                         "synchronous")}  # fmt: skip


# synchronous 1 is NORMAL
EXPECTED = {"foreign_keys": 1, "journal_mode": "wal", "secure_delete": 1, "synchronous": 1,
            "busy_timeout": SQLITE_BUSY_TIMEOUT_S * 1000}  # fmt: skip


def test_a_second_burst_reuses_the_first_ones_connections(engine: Engine) -> None:
    opened = _opened(engine)
    _burst(engine)
    assert len(opened) == AT_ONCE
    _burst(engine)
    _burst(engine)
    assert len(opened) == AT_ONCE  # none opened again: their PRAGMAs ran once


def test_a_reused_connection_keeps_every_setting(engine: Engine) -> None:
    first = _burst(engine)
    again = _burst(engine)  # the same connections, back from the pool
    assert first == again == [EXPECTED] * AT_ONCE


def test_the_pool_still_has_a_connection_for_every_request_thread(engine: Engine) -> None:
    assert engine.pool.size() == request_threads(engine)  # type: ignore[attr-defined]
