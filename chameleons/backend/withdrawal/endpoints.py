"""PI actions on a participant: withdraw (typed confirmation) and rehearsal marking."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Annotated

from fastapi import Depends, Form, HTTPException, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from pydantic import BaseModel
from sqlalchemy import func, select

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.dashboard.context import flash, page_context, study_or_404, study_query
from chameleons.backend.dependencies import AppSettings, DbSession, Templates
from chameleons.backend.models import Interaction, ParticipantVideo, Recording, Session
from chameleons.backend.routing import make_router
from chameleons.backend.withdrawal.rehearsal import RehearsalError, set_rehearsal
from chameleons.backend.withdrawal.scrub import scrub_database
from chameleons.backend.withdrawal.service import (
    ParticipantNotFoundError,
    WithdrawalError,
    WithdrawalResult,
    find_participant,
    withdraw_participant,
)

router = make_router(tags=["withdrawal"])
CSRF = [Depends(verify_csrf)]


class WithdrawRequest(BaseModel):
    confirm: str


class RehearsalRequest(BaseModel):
    rehearsal: bool


def _http_error(exc: WithdrawalError) -> HTTPException:
    if isinstance(exc, ParticipantNotFoundError):
        return HTTPException(status.HTTP_404_NOT_FOUND, str(exc))
    if isinstance(exc, RehearsalError):
        return HTTPException(status.HTTP_409_CONFLICT, str(exc))
    return HTTPException(status.HTTP_400_BAD_REQUEST, str(exc))


def withdraw_and_scrub(
    db: DbSession, study_id: int, code: str, confirmation: str, data_dir: Path
) -> WithdrawalResult:
    """Withdraw, commit, then scrub the database file. The commit comes here, not in the
    request's unit of work: SQLite's checkpoint can only move committed pages, and the
    report must say what actually happened to them."""
    result = withdraw_participant(db, study_id, code, confirmation, data_dir)
    db.commit()
    removed, kept = scrub_database(db.get_bind())  # type: ignore[arg-type]
    return replace(result, removed=result.removed + tuple(removed), kept=result.kept + tuple(kept))


def _recording_count(db: DbSession, participant_id: int) -> int:
    query = (
        select(func.count(Recording.id))
        .join(Interaction, Interaction.id == Recording.interaction_id)
        .join(Session, Session.id == Interaction.session_id)
        .where(Session.participant_id == participant_id)
    )
    return int(db.scalar(query) or 0)


def _video_count(db: DbSession, participant_id: int) -> int:
    query = (select(func.count(ParticipantVideo.id))
             .join(Session, Session.id == ParticipantVideo.session_id)
             .where(Session.participant_id == participant_id))  # fmt: skip
    return int(db.scalar(query) or 0)


def _withdraw_page(
    request: Request, templates: Templates, context: dict[str, object], status_code: int = 200
) -> Response:
    return templates.TemplateResponse(request, "pi/withdraw.html", context, status_code=status_code)


@router.get("/pi/participants/{code}/withdraw", response_class=HTMLResponse)
def withdraw_form(
    request: Request, code: str, user: CurrentPI, db: DbSession, templates: Templates,
    study: int | None = None,
) -> Response:  # fmt: skip
    found = study_or_404(db, study)
    try:
        participant = find_participant(db, found.id, code)
    except WithdrawalError as exc:
        raise _http_error(exc) from exc
    recordings = _recording_count(db, participant.id)
    context = page_context(request, user, found, "overview", code=code, recordings=recordings,
                           videos=_video_count(db, participant.id))  # fmt: skip
    return _withdraw_page(request, templates, {**context, "error": None})


@router.post("/pi/participants/{code}/withdraw", response_class=HTMLResponse, dependencies=CSRF)
def withdraw_submit(
    request: Request, code: str, user: CurrentPI, db: DbSession, settings: AppSettings,
    templates: Templates, confirm: Annotated[str, Form(max_length=64)] = "",
    study: int | None = None,
) -> Response:  # fmt: skip
    found = study_or_404(db, study)
    try:
        result = withdraw_and_scrub(db, found.id, code, confirm, settings.data_dir)
    except ParticipantNotFoundError as exc:
        raise _http_error(exc) from exc
    except WithdrawalError as exc:
        try:  # a wrong confirmation for a code that names nobody is a 404, not a 500
            participant = find_participant(db, found.id, code)
        except ParticipantNotFoundError as missing:
            raise _http_error(missing) from missing
        context = page_context(
            request, user, found, "overview", code=code,
            recordings=_recording_count(db, participant.id), error=str(exc),
            videos=_video_count(db, participant.id),
        )  # fmt: skip
        return _withdraw_page(request, templates, context, status.HTTP_400_BAD_REQUEST)
    context = page_context(request, user, found, "overview", code=code, result=result)
    return templates.TemplateResponse(
        request, "pi/withdrawn.html", context, headers={"Cache-Control": "no-store"}
    )


@router.post("/api/pi/participants/{code}/withdraw", dependencies=CSRF)
def withdraw_api(
    code: str, body: WithdrawRequest, _pi: CurrentPI, db: DbSession, settings: AppSettings,
    study: int | None = None,
) -> dict[str, object]:  # fmt: skip
    found = study_or_404(db, study)
    try:
        result = withdraw_and_scrub(db, found.id, code, body.confirm, settings.data_dir)
    except WithdrawalError as exc:
        raise _http_error(exc) from exc
    return {
        "plan_row": result.plan_row_number,
        "sessions": result.sessions,
        "files_deleted": result.files_deleted,
        "removed": list(result.removed),
        "not_removed": list(result.kept),
    }


@router.post("/pi/participants/{code}/rehearsal", dependencies=CSRF)
def rehearsal_submit(
    request: Request, code: str, _pi: CurrentPI, db: DbSession,
    rehearsal: Annotated[bool, Form()], study: int | None = None,
) -> Response:  # fmt: skip
    found = study_or_404(db, study)
    try:
        set_rehearsal(db, found.id, code, rehearsal)
    except ParticipantNotFoundError as exc:
        raise _http_error(exc) from exc
    except WithdrawalError as exc:
        flash(request, str(exc))
    else:
        state = "marked as a rehearsal" if rehearsal else "counted again (no longer a rehearsal)"
        flash(request, f"{code} {state}.")
    return RedirectResponse(f"/pi{study_query(found)}", status_code=status.HTTP_303_SEE_OTHER)


@router.post("/api/pi/participants/{code}/rehearsal", dependencies=CSRF)
def rehearsal_api(
    code: str, body: RehearsalRequest, _pi: CurrentPI, db: DbSession, study: int | None = None
) -> dict[str, object]:
    found = study_or_404(db, study)
    try:
        participant = set_rehearsal(db, found.id, code, body.rehearsal)
    except WithdrawalError as exc:
        raise _http_error(exc) from exc
    return {"participant": participant.code, "rehearsal": participant.is_rehearsal}
