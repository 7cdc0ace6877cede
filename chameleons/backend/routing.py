"""The route class of every router: a sync endpoint runs in a worker thread, and nothing
after it needs one before the request's transaction commits.

FastAPI validates a *sync* endpoint's response model in the shared thread pool too, after
the endpoint returned and before the request's function-scoped dependencies (the unit of
work in ``events.unit_of_work.get_write_db``) exit. A request that took SQLite's write lock
in its endpoint then needed one more thread token to reach its commit, while every token
was held by requests blocked in ``BEGIN IMMEDIATE`` waiting for that very lock: all of
them waited out the busy timeout (bench/server_bench.py, 50 phones on SQLite: a burst of
submissions took 30 s and failed with "database is locked"; the lock's holder was a
finished request waiting for a thread). Running the endpoint through an ``async`` wrapper
keeps the work in the thread pool but lets FastAPI validate the response in the event
loop, so the commit (on its own threads) follows the endpoint at once.

The request's write session (``WriteDb``) commits in the endpoint's own thread, right after
the endpoint returns (or rolls back when it raises): a SQLite writer holds the database's
write lock until its commit, and handing the commit to another thread first went through
the event loop, which under load is busy sending live updates, while every other writer
waited for the lock (bench/server_bench.py).
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from typing import Any

from fastapi import APIRouter
from fastapi.routing import APIRoute
from starlette.concurrency import run_in_threadpool

from chameleons.backend.db import ends_with_endpoint


def _plain_sync(endpoint: Callable[..., Any]) -> bool:
    """A sync function that is not a generator (those FastAPI streams itself)."""
    return not (
        inspect.iscoroutinefunction(endpoint)
        or inspect.isgeneratorfunction(endpoint)
        or inspect.isasyncgenfunction(endpoint)
    )


def in_thread(endpoint: Callable[..., Any]) -> Callable[..., Any]:
    """``endpoint`` as a coroutine function that runs it in the thread pool. FastAPI reads
    the signature and annotations through ``__wrapped__``, so parameters, dependencies and
    the response model are those of ``endpoint``."""
    if not _plain_sync(endpoint):
        return endpoint

    @functools.wraps(endpoint)
    async def run(*args: Any, **kwargs: Any) -> Any:
        return await run_in_threadpool(_run_and_end, endpoint, args, kwargs)

    return run


def _run_and_end(endpoint: Callable[..., Any], args: Any, kwargs: dict[str, Any]) -> Any:
    """Run ``endpoint``, then commit its write sessions (roll them back when it raised)."""
    writes = [value for value in kwargs.values() if ends_with_endpoint(value)]
    try:
        result = endpoint(*args, **kwargs)
    except BaseException:
        for db in writes:
            db.rollback()
        raise
    for db in writes:
        db.commit()
    return result


class ThreadedRoute(APIRoute):
    def __init__(self, path: str, endpoint: Callable[..., Any], **kwargs: Any) -> None:
        super().__init__(path, in_thread(endpoint), **kwargs)


def make_router(**kwargs: Any) -> APIRouter:
    """``APIRouter(**kwargs)`` whose routes are ``ThreadedRoute``: every feature package
    makes its router here (a test checks every route of the app)."""
    return APIRouter(route_class=ThreadedRoute, **kwargs)
