"""Request threads never outnumber database connections (both databases): with more
threads than connections, threads waiting for a connection can hold every thread token
while the requests holding the connections wait for one (bench/server_bench.py showed it:
QueuePool timeouts and connections idle in transaction at 50 phones on PostgreSQL)."""

from __future__ import annotations

import anyio.to_thread
from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.db import POOL_OVERFLOW, POOL_SIZE, build_engine, request_threads


def test_the_pool_has_a_connection_for_every_request_thread(
    client: TestClient, app: FastAPI
) -> None:
    assert client.portal is not None
    limiter = client.portal.call(anyio.to_thread.current_default_thread_limiter)
    tokens = limiter.total_tokens
    connections = request_threads(app.state.engine)
    assert connections == POOL_SIZE + POOL_OVERFLOW
    assert 0 < tokens <= connections
    # anyio's default of 40 threads fits: the server is not made slower than it was.
    assert tokens == min(40, connections)


def test_an_in_memory_database_keeps_its_own_pool() -> None:
    engine = build_engine("sqlite://")  # pool sizes do not apply to it: no error, it works
    try:
        with engine.connect() as connection:
            assert connection.exec_driver_sql("select 1").scalar() == 1
    finally:
        engine.dispose()
