"""The booth check's page and API: ``GET /booths/<booth>/check`` (staff) and
``POST /api/booths/<booth>/check`` (runs the check, logs ``booth.checked``)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, HTTPException, Path, Query, Request, status
from fastapi.responses import HTMLResponse, Response

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentStaff
from chameleons.backend.booth import check
from chameleons.backend.dependencies import AppSettings, Templates
from chameleons.backend.events import repository as events
from chameleons.backend.events.unit_of_work import WriteDb
from chameleons.backend.models import Session
from chameleons.backend.wizard import health, worker_link
from chameleons.backend.wizard.live import display_presence
from chameleons.backend.wizard.pages import BOOTH_PATTERN

router = APIRouter(tags=["booth"])
Booth = Annotated[str, Path(pattern=BOOTH_PATTERN)]


@router.get("/booths/{booth}/check", response_class=HTMLResponse)
def check_page(
    request: Request, booth: Booth, user: CurrentStaff, templates: Templates,
    session_id: Annotated[int | None, Query()] = None,
) -> Response:  # fmt: skip
    context = {"user": user, "booth": booth, "session_id": session_id}
    return templates.TemplateResponse(request, "booth/check.html", context)


@router.post("/api/booths/{booth}/check", dependencies=[Depends(verify_csrf)])
def run_check(
    request: Request, booth: Booth, _user: CurrentStaff, db: WriteDb, settings: AppSettings,
    session_id: Annotated[int | None, Query()] = None,
) -> dict[str, Any]:  # fmt: skip
    """Judge every step now; the result is logged with the session when one is given."""
    state = request.app.state
    session = db.get(Session, session_id) if session_id is not None else None
    if session_id is not None and (session is None or session.booth != booth):
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"No session {session_id} on {booth}.")
    telemetry, age = worker_link.latest_telemetry(worker_link.bridge_of(state), booth)
    if age is None or age > health.STALE_AFTER_SECONDS:
        telemetry = None
    result = check.run(telemetry, display_presence(state, booth), settings.data_dir)
    event = events.record(
        db, check.CHECKED, source="server",
        study_id=session.study_id if session else None,
        session_id=session.id if session else None,
        payload={"booth": booth, **result},
    )  # fmt: skip
    db.flush()
    return {"event_id": event.id, "booth": booth, **result}
