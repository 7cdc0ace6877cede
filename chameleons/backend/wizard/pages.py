"""The wizard console's pages: the session picker and the console itself."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Request, status
from fastapi.responses import HTMLResponse, Response

from chameleons.backend.auth.dependencies import CurrentStaff
from chameleons.backend.dependencies import DbSession, Templates
from chameleons.backend.wizard import repository

router = APIRouter(tags=["wizard"])


@router.get("/wizard", response_class=HTMLResponse)
def session_picker(
    request: Request, user: CurrentStaff, db: DbSession, templates: Templates
) -> Response:
    sessions = repository.recent_sessions(db)
    return templates.TemplateResponse(
        request, "wizard/index.html", {"user": user, "sessions": sessions}
    )


@router.get("/wizard/sessions/{session_id}", response_class=HTMLResponse)
def console_page(
    session_id: int, request: Request, user: CurrentStaff, db: DbSession, templates: Templates
) -> Response:
    try:
        view = repository.load_session(db, session_id)
    except repository.SessionNotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from None
    return templates.TemplateResponse(
        request,
        "wizard/console.html",
        {"user": user, "session": view.session, "participant": view.participant},
    )
