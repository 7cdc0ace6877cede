"""Login form, logout, and the staff landing page."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Form, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response

from chameleons.backend.auth import service, sessions
from chameleons.backend.auth.csrf import rotate_csrf_token, verify_csrf
from chameleons.backend.auth.dependencies import CurrentStaff
from chameleons.backend.auth.throttle import LoginThrottle
from chameleons.backend.dependencies import DbSession, Templates
from chameleons.backend.routing import make_router

router = make_router(tags=["auth"])


def _safe_next(next_path: str | None) -> str:
    # Only local paths: an open redirect would let a phishing link bounce through /login.
    if next_path and next_path.startswith("/") and not next_path.startswith("//"):
        return next_path
    return "/"


@router.get("/login", response_class=HTMLResponse)
def login_form(request: Request, templates: Templates, next: str | None = None) -> Response:
    return templates.TemplateResponse(
        request, "login.html", {"next": _safe_next(next), "error": None, "username": ""}
    )


@router.post("/login", response_class=HTMLResponse, dependencies=[Depends(verify_csrf)])
def login(
    request: Request,
    db: DbSession,
    templates: Templates,
    username: Annotated[str, Form(max_length=64)] = "",
    password: Annotated[str, Form(max_length=256)] = "",
    next: Annotated[str, Form()] = "/",
) -> Response:
    throttle: LoginThrottle = request.app.state.login_throttle
    client = request.client.host if request.client else "unknown"
    keys = LoginThrottle.keys(username, client)
    wait = throttle.retry_after(*keys)
    error: str | None = None
    status_code = status.HTTP_200_OK
    if wait > 0:
        error = f"Too many failed attempts. Try again in {int(wait) + 1} seconds."
        status_code = status.HTTP_429_TOO_MANY_REQUESTS
    else:
        user = service.authenticate(db, username, password)
        if user is not None:
            throttle.reset(*keys)
            request.session.clear()
            hours = request.app.state.settings.staff_session_hours
            request.session[sessions.SESSION_KEY] = sessions.start(db, user, hours)
            rotate_csrf_token(request)
            return RedirectResponse(_safe_next(next), status_code=status.HTTP_303_SEE_OTHER)
        throttle.record_failure(*keys)
        error = "Wrong username or password."
        status_code = status.HTTP_401_UNAUTHORIZED
    return templates.TemplateResponse(
        request,
        "login.html",
        {"next": _safe_next(next), "error": error, "username": username},
        status_code=status_code,
    )


@router.post("/logout", dependencies=[Depends(verify_csrf)])
def logout(request: Request, db: DbSession) -> Response:
    """Ends the session on the server too: the cookie, if kept or replayed, is dead."""
    sessions.end(db, request.session)
    request.session.clear()
    return RedirectResponse("/login", status_code=status.HTTP_303_SEE_OTHER)


@router.post("/logout/everywhere", dependencies=[Depends(verify_csrf)])
def logout_everywhere(request: Request, user: CurrentStaff, db: DbSession) -> Response:
    """End every session of this account (a lost laptop, a shared browser)."""
    sessions.end_all(db, user.id, "logged out everywhere")
    request.session.clear()
    return RedirectResponse("/login", status_code=status.HTTP_303_SEE_OTHER)


# (label, url, what it is for, PI only)
STAFF_LINKS = (
    ("Wizard console", "/wizard", "Run a session: prompts, condition, negotiation.", False),
    ("Robot display", "/display", "The virtual robot's face for the booth screen.", False),
    ("PI dashboard", "/pi", "Progress, balance, sessions, data quality.", True),
    ("Analysis", "/pi/analysis", "Table I, Friedman tests, plots, LaTeX.", True),
    ("Export", "/pi/export", "Data for R and pandas.", True),
    ("Study and plan", "/studies", "Create the study and its counterbalancing plan.", True),
    ("Staff accounts", "/pi/staff", "Add, deactivate and log out staff accounts.", True),
)


@router.get("/", response_class=HTMLResponse)
def staff_home(request: Request, user: CurrentStaff, templates: Templates) -> Response:
    links = [
        {"label": label, "url": url, "hint": hint}
        for label, url, hint, pi_only in STAFF_LINKS
        if user.role == "pi" or not pi_only
    ]
    return templates.TemplateResponse(
        request, "staff_home.html", {"user": user, "staff_links": links}
    )
