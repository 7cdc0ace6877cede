"""The FastAPI application factory. Nothing is built at import time."""

from __future__ import annotations

import logging
import secrets
from collections import Counter
from collections.abc import AsyncIterator
from contextlib import AsyncExitStack, asynccontextmanager
from pathlib import Path

import anyio.to_thread
from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, PlainTextResponse, RedirectResponse, Response
from fastapi.staticfiles import StaticFiles
from fastapi.templating import Jinja2Templates
from starlette.middleware.sessions import SessionMiddleware

from chameleons import __version__
from chameleons.backend import apidocs, logredact
from chameleons.backend.analysis import pages as analysis_pages
from chameleons.backend.auth import endpoints as auth_endpoints
from chameleons.backend.auth import pages as auth_pages
from chameleons.backend.auth import socket_revocation, staff_pages
from chameleons.backend.auth.csrf import csrf_token
from chameleons.backend.auth.dependencies import LoginRequiredError, PIRequiredError
from chameleons.backend.auth.throttle import LoginThrottle
from chameleons.backend.booth import check_endpoints as booth_check
from chameleons.backend.bridge.wiring import worker_link
from chameleons.backend.capture import endpoints as capture_endpoints
from chameleons.backend.capture import pages as capture_pages
from chameleons.backend.dashboard import monitor as dashboard_monitor
from chameleons.backend.dashboard import pages as dashboard_pages
from chameleons.backend.db import (
    build_engine,
    build_read_sessionmaker,
    build_sessionmaker,
    request_threads,
)
from chameleons.backend.display import endpoints as display_endpoints
from chameleons.backend.display import media as display_media
from chameleons.backend.display import pages as display_pages
from chameleons.backend.dropouts import endpoints as dropout_endpoints
from chameleons.backend.events.hub import LiveHub
from chameleons.backend.events.pg_fanout import fan_out
from chameleons.backend.export import endpoints as export_endpoints
from chameleons.backend.health import endpoints as health_endpoints
from chameleons.backend.input_guard import InputGuardMiddleware
from chameleons.backend.instruments import pages as instrument_pages
from chameleons.backend.phone import endpoints as phone_endpoints
from chameleons.backend.phone import pages as phone_pages
from chameleons.backend.planning import pages as planning_pages
from chameleons.backend.security_headers import SECURITY_HEADERS, SecurityHeadersMiddleware
from chameleons.backend.sessions import endpoints as session_endpoints
from chameleons.backend.sessions import live as session_live
from chameleons.backend.studies import endpoints as study_endpoints
from chameleons.backend.studies import pages as study_pages
from chameleons.backend.synchrony import pages as synchrony_pages
from chameleons.backend.video import endpoints as video_endpoints
from chameleons.backend.video import pages as video_pages
from chameleons.backend.withdrawal import endpoints as withdrawal_endpoints
from chameleons.backend.wizard import endpoints as wizard_endpoints
from chameleons.backend.wizard import live as wizard_live
from chameleons.backend.wizard import pages as wizard_pages
from chameleons.backend.wizard import typed_speech
from chameleons.experiment.stats.rounding import fmt, fmt_p
from chameleons.i18n import jinja as i18n_jinja
from chameleons.settings import Settings

FRONTEND_DIR = Path(__file__).resolve().parent.parent / "frontend"
log = logging.getLogger(__name__)


def build_templates() -> Jinja2Templates:
    templates = Jinja2Templates(directory=str(FRONTEND_DIR / "templates"))
    templates.env.globals["csrf_token"] = csrf_token
    i18n_jinja.install(templates.env)  # the phone pages speak the participant's language
    templates.env.globals["app_version"] = __version__
    # One rounding rule for every number a page shows (see experiment.stats.rounding).
    templates.env.globals["fmt"] = fmt
    templates.env.globals["fmt_p"] = fmt_p
    return templates


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()
    settings.require_secure()
    logredact.install()
    engine = build_engine(settings.effective_database_url)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        # Sync endpoints and dependencies run in anyio's thread pool: never more threads
        # than database connections (see chameleons.backend.db.POOL_SIZE).
        limiter = anyio.to_thread.current_default_thread_limiter()
        wanted = settings.request_threads or limiter.total_tokens
        limiter.total_tokens = min(wanted, request_threads(engine))
        app.state.request_limiter = limiter  # read by tests and the benchmark
        # Typed speech needs espeak-ng: found out now, shown on the console's health strip.
        synthesiser = await anyio.to_thread.run_sync(typed_speech.check_synthesiser)
        app.state.typed_speech = synthesiser
        if not synthesiser.available:
            log.warning("Typed speech (the console's Say field) cannot speak: %s.",
                        synthesiser.detail)  # fmt: skip
        async with AsyncExitStack() as stack:
            await stack.enter_async_context(
                socket_revocation.revoking(app, settings.staff_socket_recheck_s)
            )
            if settings.live_fanout:
                app.state.live_fanout = await stack.enter_async_context(
                    fan_out(app.state.live_hub, settings.effective_database_url)
                )
            if settings.bridge_enabled:
                await stack.enter_async_context(worker_link(app, settings))
            if settings.lsl:  # LSL markers of each booth's timeline (docs/instruments.md)
                from chameleons.backend.instruments.markers import publishing

                await stack.enter_async_context(publishing(app))
            yield
        engine.dispose()

    # /docs is served by apidocs (its own Content-Security-Policy); ReDoc would repeat it.
    app = FastAPI(
        title="Mechanical Chameleons",
        version=__version__,
        lifespan=lifespan,
        docs_url=None,
        redoc_url=None,
    )
    app.state.settings = settings
    app.state.engine = engine
    app.state.sessionmaker = build_sessionmaker(engine)
    app.state.read_sessionmaker = build_read_sessionmaker(engine)
    app.state.templates = build_templates()
    app.state.live_hub = LiveHub()
    app.state.socket_guard_counters = Counter()  # sockets closed by events.guard, by code
    app.state.staff_sockets = socket_revocation.StaffSockets()  # open staff WebSockets
    app.state.bridge = None  # set while the worker link runs (lifespan)
    app.state.typed_speech = None  # the start-up's espeak-ng check (lifespan)
    app.state.live_fanout = None  # PostgreSQL: set while the server runs (lifespan)
    app.state.lsl_markers = None  # settings.lsl: set while the server runs (lifespan)
    app.state.login_throttle = LoginThrottle(
        settings.login_max_failures, settings.login_lockout_seconds
    )
    app.add_middleware(
        SessionMiddleware,
        # Demo mode may run without a key: then sessions last only as long as this process.
        secret_key=settings.secret_key.get_secret_value() or secrets.token_urlsafe(32),
        session_cookie="chameleons_session",
        same_site="lax",
        https_only=settings.cookie_secure,
        max_age=int(settings.staff_session_hours * 3600),
    )
    app.add_middleware(InputGuardMiddleware)  # NUL, NaN, numbers >= 2**63: a 4xx, not a 500
    # Added last, so it is outermost: errors, refusals and redirects get the headers too.
    app.add_middleware(SecurityHeadersMiddleware)

    @app.exception_handler(Exception)
    async def _server_error(_request: Request, _exc: Exception) -> Response:
        # Starlette answers an unhandled exception outside every middleware (and re-raises
        # it for the log): this 500 carries the security headers itself, and no details.
        return PlainTextResponse("Internal Server Error", 500, headers=SECURITY_HEADERS)

    @app.exception_handler(PIRequiredError)
    async def _pi_only(request: Request, _exc: PIRequiredError) -> Response:
        return app.state.templates.TemplateResponse(  # type: ignore[no-any-return]
            request, "forbidden.html", {"user": None}, status_code=403
        )

    @app.get("/favicon.ico", include_in_schema=False)
    async def _favicon() -> Response:
        return FileResponse(FRONTEND_DIR / "static" / "favicon.svg", media_type="image/svg+xml")

    @app.exception_handler(LoginRequiredError)
    async def _to_login(_request: Request, exc: LoginRequiredError) -> Response:
        return RedirectResponse(f"/login?next={exc.next_path}", status_code=303)

    app.mount("/static", StaticFiles(directory=FRONTEND_DIR / "static"), name="static")
    # A request is matched against the routers in this order, route by route (about 4
    # microseconds a route with FastAPI's included routers): the routers of a running
    # session's many requests come first, the phone's submissions and the wizard's actions
    # (issue 34: a phone's ranking was matched against 40 routes before its own). No path
    # of one router is a path of another, so the order changes no route's meaning
    # (tests/backend/test_route_order.py).
    for router in (
        phone_endpoints.router,
        session_endpoints.router,
        wizard_endpoints.router,
        health_endpoints.router,
        apidocs.router,
        auth_pages.router,
        auth_endpoints.router,
        staff_pages.router,
        study_endpoints.router,
        study_pages.router,
        session_live.router,
        phone_pages.router,
        export_endpoints.router,
        analysis_pages.router,
        planning_pages.router,
        dashboard_pages.router,
        dashboard_monitor.router,
        withdrawal_endpoints.router,
        dropout_endpoints.router,
        display_pages.router,
        display_endpoints.router,
        display_media.router,
        wizard_pages.router,
        wizard_live.router,
        typed_speech.router,
        booth_check.router,
        synchrony_pages.router,
        instrument_pages.router,
        capture_pages.router,
        capture_endpoints.router,
        video_pages.router,
        video_endpoints.router,
    ):
        app.include_router(router)
    return app
