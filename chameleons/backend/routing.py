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
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from typing import Any

from fastapi import APIRouter
from fastapi.routing import APIRoute
from starlette.concurrency import run_in_threadpool


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
        return await run_in_threadpool(endpoint, *args, **kwargs)

    return run


class ThreadedRoute(APIRoute):
    def __init__(self, path: str, endpoint: Callable[..., Any], **kwargs: Any) -> None:
        super().__init__(path, in_thread(endpoint), **kwargs)


def make_router(**kwargs: Any) -> APIRouter:
    """``APIRouter(**kwargs)`` whose routes are ``ThreadedRoute``: every feature package
    makes its router here (a test checks every route of the app)."""
    return APIRouter(route_class=ThreadedRoute, **kwargs)
