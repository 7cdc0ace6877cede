"""SQLite's writers queue in this process, first come first served, instead of in SQLite's
busy handler.

A connection that finds the write lock taken sleeps in SQLite's busy handler and looks
again after 1, 2, 5 ... up to 100 ms; whoever looks first after a commit wins. With dozens
of phones submitting at once the lock sat idle between writers and an unlucky request
could lose every round (bench/server_bench.py, 50 phones: seconds at p99). Here a writer
waits on its own event, handed the gate by the previous writer's commit or rollback, and
then takes SQLite's lock at once. Other processes (the CLI, a second server) still meet
SQLite's busy handler as before.
"""

from __future__ import annotations

import threading
from collections import deque
from typing import Any
from weakref import WeakKeyDictionary

from sqlalchemy import Engine, event
from sqlalchemy.engine import Connection

_HELD = "chameleons_write_gate"


class WriteGate:
    """A lock that wakes its waiters in the order they came."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._held = False
        self._waiting: deque[threading.Event] = deque()

    def acquire(self, timeout: float) -> bool:
        with self._lock:
            if not self._held and not self._waiting:
                self._held = True
                return True
            turn = threading.Event()
            self._waiting.append(turn)
        if turn.wait(timeout):
            return True
        with self._lock:
            if turn.is_set():  # handed over between the timeout and this line
                return True
            self._waiting.remove(turn)
            return False

    def release(self) -> None:
        with self._lock:
            if self._waiting:
                self._waiting.popleft().set()  # the gate passes on, still held
            else:
                self._held = False


_GATES: WeakKeyDictionary[Engine, WriteGate] = WeakKeyDictionary()


def install(engine: Engine) -> None:
    """Give a SQLite engine its gate; the connection's commit or rollback releases it."""
    _GATES[engine] = WriteGate()
    event.listen(engine, "commit", _release)
    event.listen(engine, "rollback", _release)
    # A connection returned to the pool without either (its session closed) is rolled back
    # by the pool's reset; this catches that and any other way out.
    event.listen(engine.pool, "checkin", _release_record)


def enter(connection: Connection, timeout: float) -> None:
    """Wait for this connection's turn to write (nothing if the engine has no gate or the
    connection holds it). Past ``timeout`` the caller goes on to SQLite's own wait, which
    reports "database is locked" as before."""
    gate = _GATES.get(connection.engine)
    if gate is None or connection.info.get(_HELD):
        return
    if gate.acquire(timeout):
        connection.info[_HELD] = gate


def _release(connection: Connection) -> None:
    gate: WriteGate | None = connection.info.pop(_HELD, None)
    if gate is not None:
        gate.release()


def _release_record(_dbapi_connection: Any, record: Any) -> None:
    gate: WriteGate | None = record.info.pop(_HELD, None)
    if gate is not None:
        gate.release()
