"""The robot display page (booth screen) and the staff page that lists its links."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, HTTPException, Query, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from sqlalchemy import select

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentPI, CurrentStaff
from chameleons.backend.dependencies import AppSettings, DbSession, Templates
from chameleons.backend.display import links
from chameleons.backend.display.channel import get_display_channel
from chameleons.backend.display.protocol import FACE_IDS
from chameleons.backend.display.tokens import (
    BOOTH_PATTERN,
    display_path,
    is_valid_booth,
    signing_key,
)
from chameleons.backend.models import Session
from chameleons.backend.routing import make_router

router = make_router(tags=["display"])

DEFAULT_BOOTH = "booth-1"


def _render(request: Request, templates: Templates, booth: str, token: str | None) -> Response:
    query = f"?token={token}" if token else ""
    context = {
        "booth": booth,
        "ws_path": f"/ws/display/{booth}{query}",
        "faces": FACE_IDS,
        "initial_face": FACE_IDS[0],
    }
    response = templates.TemplateResponse(request, "display/robot.html", context)
    # The link is the credential: keep it out of other sites' logs and out of caches.
    response.headers["Referrer-Policy"] = "no-referrer"
    response.headers["Cache-Control"] = "no-store"
    return response


@router.get("/display", response_class=HTMLResponse)
def display_links(
    request: Request,
    user: CurrentStaff,
    db: DbSession,
    settings: AppSettings,
    templates: Templates,
    booth: Annotated[str | None, Query(max_length=64)] = None,
) -> Response:
    """Staff: the unguessable display link of every known booth (and of one typed in)."""
    booths = {DEFAULT_BOOTH, *db.scalars(select(Session.booth).distinct())}
    error = None
    if booth:
        if is_valid_booth(booth):
            booths.add(booth)
        else:
            error = "A booth id uses letters, digits, '-', '_' and '.' (at most 64)."
    key = signing_key(request.app)
    base = settings.effective_public_url
    booths |= links.retired_booths(db)
    rows = []
    for b in sorted(booths):
        current = links.generation(db, b)
        rows.append((b, None if current is None else base + display_path(key, b, current)))
    context = {
        "user": user,
        "links": rows,
        "error": error,
        "booth_pattern": BOOTH_PATTERN[1:-1],
        "is_pi": user.role == "pi",
    }
    return templates.TemplateResponse(request, "display/links.html", context)


@router.post("/display/{booth}/rotate", dependencies=[Depends(verify_csrf)])
def rotate_link(request: Request, booth: str, _user: CurrentPI, db: DbSession) -> Response:
    """PI: a new link for the booth; pages open with the old one are disconnected."""
    _valid_or_404(booth)
    links.rotate(db, booth)
    get_display_channel(request.app).revoke(booth, "display link rotated by the PI")
    return RedirectResponse("/display", status_code=status.HTTP_303_SEE_OTHER)


@router.post("/display/{booth}/retire", dependencies=[Depends(verify_csrf)])
def retire_link(request: Request, booth: str, _user: CurrentPI, db: DbSession) -> Response:
    """PI: the booth is out of use; its link stops working (a rotation issues a new one)."""
    _valid_or_404(booth)
    links.retire(db, booth)
    get_display_channel(request.app).revoke(booth, "booth retired by the PI")
    return RedirectResponse("/display", status_code=status.HTTP_303_SEE_OTHER)


def _valid_or_404(booth: str) -> None:
    if not is_valid_booth(booth):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such booth.")


@router.get("/display/{booth}", response_class=HTMLResponse)
def staff_display(
    request: Request, booth: str, _user: CurrentStaff, templates: Templates
) -> Response:
    """The display for a logged-in staff member (no token in the link)."""
    if not is_valid_booth(booth):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such booth.")
    return _render(request, templates, booth, None)


@router.get("/display/{booth}/{token}", response_class=HTMLResponse)
def booth_display(
    request: Request, booth: str, token: str, templates: Templates, db: DbSession
) -> Response:
    """The booth screen's own link: works without a login, 404 for a wrong, rotated or
    retired one."""
    if not is_valid_booth(booth) or not links.token_works(db, request.app, booth, token):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such display.")
    return _render(request, templates, booth, token)
