"""SQLite writers of this process take turns in the order they came (chameleons.backend.
write_gate): a commit, a rollback or a session closed without either passes the turn on."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from sqlalchemy import Engine, text
from sqlalchemy.orm import Session

from chameleons.backend import write_gate
from chameleons.backend.db import build_engine, build_sessionmaker, write_transaction
from chameleons.backend.write_gate import WriteGate

WAIT_S = 60.0


def wait_until(condition: Callable[[], bool]) -> None:
    deadline = time.monotonic() + WAIT_S
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.005)


def queued(gate: WriteGate) -> int:
    return len(gate._waiting)


def test_waiters_are_served_in_the_order_they_came() -> None:
    gate = WriteGate()
    assert gate.acquire(WAIT_S)
    order: list[int] = []

    def writer(number: int) -> None:
        assert gate.acquire(WAIT_S)
        order.append(number)
        gate.release()

    threads = []
    for number in range(5):
        thread = threading.Thread(target=writer, args=(number,))
        thread.start()
        threads.append(thread)
        wait_until(lambda n=number: queued(gate) == n + 1)  # type: ignore[misc]
    gate.release()
    for thread in threads:
        thread.join(WAIT_S)
    assert order == [0, 1, 2, 3, 4]
    assert gate.acquire(0)  # free again


def test_a_waiter_that_gives_up_leaves_the_queue() -> None:
    gate = WriteGate()
    assert gate.acquire(WAIT_S)
    assert gate.acquire(0.01) is False
    assert queued(gate) == 0
    gate.release()
    assert gate.acquire(0)


@pytest.fixture
def sqlite_engine(tmp_path: Path) -> Iterator[Engine]:
    engine = build_engine(f"sqlite:///{tmp_path / 'gate.sqlite3'}")
    with engine.begin() as connection:
        connection.execute(text("CREATE TABLE t (writer TEXT)"))
    yield engine
    engine.dispose()


@pytest.mark.parametrize("ending", ["commit", "rollback", "close"])
def test_the_turn_passes_on_when_a_writer_ends(sqlite_engine: Engine, ending: str) -> None:
    factory = build_sessionmaker(sqlite_engine)
    gate = write_gate._GATES[sqlite_engine]
    first = factory()
    write_transaction(first)
    first.execute(text("INSERT INTO t VALUES ('first')"))
    second_wrote = threading.Event()

    def second_writer() -> None:
        with factory() as second:
            write_transaction(second)
            second.execute(text("INSERT INTO t VALUES ('second')"))
            second.commit()
        second_wrote.set()

    thread = threading.Thread(target=second_writer)
    thread.start()
    wait_until(lambda: queued(gate) == 1)
    assert not second_wrote.is_set()
    if ending == "commit":
        first.commit()
    elif ending == "rollback":
        first.rollback()
    first.close()
    thread.join(WAIT_S)
    assert second_wrote.is_set()
    with Session(sqlite_engine) as db:
        rows = [r[0] for r in db.execute(text("SELECT writer FROM t ORDER BY rowid"))]
    assert rows == (["first", "second"] if ending == "commit" else ["second"])
    assert gate.acquire(0)  # nobody holds it any more
