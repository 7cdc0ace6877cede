"""The wizard console's pages: the session picker (which also registers the next participant
and opens their session) and the console itself."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Form, HTTPException, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from sqlalchemy.orm import Session

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentStaff
from chameleons.backend.booth.behaviour import demo_clip_warning
from chameleons.backend.dependencies import DbSession, Templates
from chameleons.backend.events.unit_of_work import WriteDb
from chameleons.backend.input_guard import MAX_ROW_ID
from chameleons.backend.models import StaffUser
from chameleons.backend.routing import make_router
from chameleons.backend.sessions import service as sessions
from chameleons.backend.studies import service as studies
from chameleons.backend.studies.errors import FlowError
from chameleons.backend.studies.specs import spec_of
from chameleons.backend.wizard import readiness, repository

router = make_router(tags=["wizard"])
BOOTH_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$"


def _picker(
    request: Request,
    templates: Templates,
    db: Session,
    user: StaffUser,
    error: str | None = None,
) -> Response:
    active = [study for study in studies.list_studies(db) if study.is_active]
    # The participant's language: any the active studies declare (a study refuses others).
    languages = sorted({lang for study in active for lang in spec_of(study).languages})
    # Languages whose prompts cannot run a session of some active study (refused for it).
    gaps = {
        f"{study.id} · {study.name}: {language}": why
        for study in active
        for language, why in readiness.study_warnings(request.app.state, spec_of(study)).items()
    }
    clips = {
        f"{study.id} · {study.name}": warning
        for study in active
        if (warning := demo_clip_warning(request.app.state, spec_of(study)))
    }
    return templates.TemplateResponse(
        request,
        "wizard/index.html",
        {
            "user": user,
            "sessions": repository.recent_sessions(db),
            "studies": active,
            "languages": languages,
            "prompt_gaps": gaps,
            "natural_clips": clips,
            "error": error,
        },
        status_code=status.HTTP_200_OK if error is None else status.HTTP_409_CONFLICT,
    )


@router.get("/wizard", response_class=HTMLResponse)
def session_picker(
    request: Request, user: CurrentStaff, db: DbSession, templates: Templates
) -> Response:
    return _picker(request, templates, db, user)


@router.post("/wizard/sessions", response_class=HTMLResponse, dependencies=[Depends(verify_csrf)])
def open_session(
    request: Request,
    user: CurrentStaff,
    db: WriteDb,
    templates: Templates,
    study_id: Annotated[int, Form(ge=1, le=MAX_ROW_ID)],
    booth: Annotated[str, Form(pattern=BOOTH_PATTERN)] = "booth-1",
    participant_code: Annotated[str, Form(max_length=32)] = "",
    rehearsal: Annotated[bool, Form()] = False,
    language: Annotated[str, Form(max_length=16)] = "",
) -> Response:
    """Register the next participant (or take a registered one by code) and open their
    session, then go to its console."""
    try:
        study = studies.get_study(db, study_id)
        code = participant_code.strip().upper()
        participant = (
            studies.participant_by_code(db, study, code)
            if code
            else studies.register_participant(db, study, rehearsal)
        )
        flow = sessions.create_session(db, study, participant, booth, language or None)
        readiness.require_prompts(request.app.state, flow)
    except FlowError as exc:
        db.rollback()  # nothing of a refused request is kept (not even the registration)
        return _picker(request, templates, db, user, exc.message)
    return RedirectResponse(
        f"/wizard/sessions/{flow.session.id}", status_code=status.HTTP_303_SEE_OTHER
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
