"""The routers' order (``create_app``): the phone's and the wizard's routers are matched
first (issue 34: a phone's ranking was matched against 40 routes before its own), and the
order changes no route's meaning: every route's own path reaches that route."""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Any

from fastapi import FastAPI
from fastapi.routing import APIWebSocketRoute
from starlette.routing import BaseRoute, Match, Mount, WebSocketRoute

from chameleons.backend.phone import endpoints as phone_endpoints
from chameleons.backend.sessions import endpoints as session_endpoints
from chameleons.backend.wizard import endpoints as wizard_endpoints


def _leaves(app: FastAPI) -> Iterator[BaseRoute]:
    for route in app.router.routes:
        inner = getattr(route, "original_router", None)
        yield from (inner.routes if inner is not None else [route])


def _scope(app: FastAPI, route: BaseRoute, method: str) -> dict[str, Any]:
    websocket = isinstance(route, WebSocketRoute | APIWebSocketRoute)
    path = re.sub(r"\{[^}]+\}", "1", getattr(route, "path", ""))  # each parameter: "1"
    return {"type": "websocket" if websocket else "http", "path": path, "root_path": "",
            "method": method, "headers": [], "query_string": b"", "app": app}  # fmt: skip


def _first_match(routes: list[BaseRoute], scope: dict[str, Any]) -> BaseRoute | None:
    """The route Starlette's router picks: the first full match, else the first partial."""
    partial = None
    for route in routes:
        match, _child = route.matches(scope)
        if match == Match.FULL:
            return route
        if match == Match.PARTIAL and partial is None:
            partial = route
    return partial


def _resolve(app: FastAPI, scope: dict[str, Any]) -> BaseRoute | None:
    found = _first_match(app.router.routes, scope)
    inner = getattr(found, "original_router", None)
    return _first_match(inner.routes, scope) if inner is not None else found


def test_every_route_is_reached_by_its_own_path(app: FastAPI) -> None:
    checked, shadowed = 0, []
    for route in _leaves(app):
        if isinstance(route, Mount):
            continue
        websocket = isinstance(route, WebSocketRoute | APIWebSocketRoute)
        for method in ["GET"] if websocket else sorted(getattr(route, "methods", None) or []):
            found = _resolve(app, _scope(app, route, method))
            checked += 1
            if found is not route:
                shadowed.append(f"{method} {getattr(route, 'path', route)} -> "
                                f"{getattr(found, 'path', found)}")  # fmt: skip
    assert checked > 100  # every route of the app, not a few
    assert shadowed == []


def test_the_running_sessions_routers_are_matched_first(app: FastAPI) -> None:
    included = [getattr(route, "original_router", None) for route in app.router.routes]
    routers = [router for router in included if router is not None]
    assert routers[:3] == [phone_endpoints.router, session_endpoints.router,
                           wizard_endpoints.router]  # fmt: skip
