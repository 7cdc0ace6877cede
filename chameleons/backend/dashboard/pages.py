"""PI dashboard pages: overview (progress, balance, sessions), session detail, export form,
recording downloads; plus the overview as JSON."""

from __future__ import annotations

from typing import Any

from fastapi import HTTPException, Request, status
from fastapi.responses import FileResponse, HTMLResponse, Response

from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.dashboard.context import page_context, study_or_404
from chameleons.backend.dashboard.progress import live_balance, plan_progress
from chameleons.backend.dashboard.sessions import session_detail, session_summaries
from chameleons.backend.dashboard.suggestion_mix import suggestion_mix
from chameleons.backend.dependencies import AppSettings, DbSession, Templates
from chameleons.backend.export.preview import PREVIEW_ROWS
from chameleons.backend.export.preview import preview as export_preview
from chameleons.backend.export.selection import StudyNotFoundError, resolve_study
from chameleons.backend.instruments.xdf_import import streams_of
from chameleons.backend.models import Recording, Session, Study
from chameleons.backend.routing import make_router
from chameleons.backend.sessions.states import END_REASONS
from chameleons.backend.synchrony import repository as synchrony_repository
from chameleons.backend.withdrawal.files import in_recordings, recording_file
from chameleons.experiment.balance import balance_summary
from chameleons.experiment.study import study_from_config

router = make_router(tags=["dashboard"])
FLAG_LABELS = {
    "not_started": "not started",
    "ended_early": "ended early",
    "partial": "partial interaction",
    "excluded": "excluded",
    "missing_answers": "missing answers",
    "deviation": "plan deviation",
    "outage": "outage",
    "not_voiced": "prompt not voiced",
    "latency": "slow wizard/worker",
    "typed_speech": "typed speech",
    "recording": "recording failed",
    "synchrony": "manipulation check failed",
}
BAD_FLAGS = ("deviation", "outage", "ended_early", "excluded", "partial", "not_voiced",
             "recording", "synchrony")  # fmt: skip


def _overview(db: DbSession, study: Study, include_rehearsal: bool) -> dict[str, Any]:
    spec = study_from_config(study.config)
    report, tables = live_balance(db, study, spec, include_rehearsal)
    return {
        "progress": plan_progress(db, study),
        "balance": report,
        "balance_summary": balance_summary(report),
        "balance_tables": tables,
        "sessions": session_summaries(db, study, spec),
        "suggestion_mix": suggestion_mix(db, study, spec, include_rehearsal),
        "include_rehearsal": include_rehearsal,
        "flag_labels": FLAG_LABELS,
        "bad_flags": BAD_FLAGS,
    }


@router.get("/pi", response_class=HTMLResponse)
def overview_page(
    request: Request,
    user: CurrentPI,
    db: DbSession,
    templates: Templates,
    study: int | None = None,
    include_rehearsal: bool = False,
) -> Response:
    try:
        found = resolve_study(db, study)
    except StudyNotFoundError as exc:
        context = page_context(request, user, None, "overview", message=str(exc))
        return templates.TemplateResponse(
            request, "pi/no_study.html", context, status_code=status.HTTP_404_NOT_FOUND
        )
    context = page_context(
        request, user, found, "overview", **_overview(db, found, include_rehearsal)
    )
    return templates.TemplateResponse(request, "pi/overview.html", context)


@router.get("/api/pi/overview")
def overview_api(
    _pi: CurrentPI, db: DbSession, study: int | None = None, include_rehearsal: bool = False
) -> dict[str, Any]:
    found = study_or_404(db, study)
    data = _overview(db, found, include_rehearsal)
    return {
        "study": {"id": found.id, "name": found.name, "config_hash": found.config_hash},
        "progress": data["progress"].__dict__,
        "balance": data["balance"].to_dict(),
        "sessions": [summary.to_dict() for summary in data["sessions"]],
        "suggestion_mix": data["suggestion_mix"].to_dict(),
    }


@router.get("/pi/sessions/{session_id}", response_class=HTMLResponse)
def session_page(
    request: Request,
    session_id: int,
    user: CurrentPI,
    db: DbSession,
    settings: AppSettings,
    templates: Templates,
) -> Response:
    session = db.get(Session, session_id)
    if session is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no session {session_id}.")
    study = study_or_404(db, session.study_id)
    spec = study_from_config(study.config)
    detail = session_detail(db, spec, session_id, settings.data_dir)
    ids = [d.interaction.id for d in detail.interactions] if detail else []
    context = page_context(
        request,
        user,
        study,
        "overview",
        detail=detail,
        synchrony=synchrony_repository.stored(db, ids),
        instruments=streams_of(db, session_id),
        spec=spec,
        flag_labels=FLAG_LABELS,
        bad_flags=BAD_FLAGS,
        end_reasons=END_REASONS,
    )
    return templates.TemplateResponse(request, "pi/session.html", context)


@router.get("/pi/recordings/{recording_id}")
def recording_download(
    recording_id: int, _pi: CurrentPI, db: DbSession, settings: AppSettings
) -> Response:
    recording = db.get(Recording, recording_id)
    if recording is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no recording {recording_id}.")
    path = recording_file(settings.data_dir, recording.path)
    if not in_recordings(settings.data_dir, path):  # a row indexed from a forged message
        raise HTTPException(status.HTTP_404_NOT_FOUND, "The recording is not in the data folder.")
    if not path.is_file():
        raise HTTPException(status.HTTP_404_NOT_FOUND, "The recording's file is missing.")
    name = f"recording-{recording.id}-{recording.stream}{path.suffix}"
    return FileResponse(path, filename=name, media_type="application/octet-stream")


@router.get("/pi/export", response_class=HTMLResponse)
def export_page(
    request: Request, user: CurrentPI, db: DbSession, templates: Templates, study: int | None = None
) -> Response:
    found = study_or_404(db, study)
    context = page_context(request, user, found, "export")
    context["preview"] = export_preview(db, found.id)
    context["preview_rows"] = PREVIEW_ROWS
    return templates.TemplateResponse(request, "pi/export.html", context)
