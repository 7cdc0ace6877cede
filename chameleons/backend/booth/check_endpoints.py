"""The booth check's page and API: ``GET /booths/<booth>/check`` (staff) and
``POST /api/booths/<booth>/check`` (runs the check, logs ``booth.checked``)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import Depends, HTTPException, Path, Query, Request, status
from fastapi.responses import HTMLResponse, Response
from sqlalchemy.orm import Session as DbSession
from starlette.concurrency import run_in_threadpool

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentStaff
from chameleons.backend.booth import check
from chameleons.backend.booth.check_store import store
from chameleons.backend.booth.speech_test import say_test_prompt
from chameleons.backend.dependencies import AppSettings, Templates
from chameleons.backend.models import Session
from chameleons.backend.routing import make_router
from chameleons.backend.wizard import health, worker_link
from chameleons.backend.wizard.live import display_presence
from chameleons.backend.wizard.pages import BOOTH_PATTERN
from chameleons.backend.wizard.playback import read, write

router = make_router(tags=["booth"])
Booth = Annotated[str, Path(pattern=BOOTH_PATTERN)]


@router.get("/booths/{booth}/check", response_class=HTMLResponse)
def check_page(
    request: Request, booth: Booth, user: CurrentStaff, templates: Templates,
    session_id: Annotated[int | None, Query()] = None,
) -> Response:  # fmt: skip
    context = {"user": user, "booth": booth, "session_id": session_id}
    return templates.TemplateResponse(request, "booth/check.html", context)


@router.post("/api/booths/{booth}/check", dependencies=[Depends(verify_csrf)])
async def run_check(
    request: Request, booth: Booth, _user: CurrentStaff, settings: AppSettings,
    session_id: Annotated[int | None, Query()] = None,
    say: Annotated[bool, Query(description="Play the test prompt (speech step).")] = True,
) -> dict[str, Any]:  # fmt: skip
    """Judge every step now; stored as a ``booth_check`` row (and ``booth.checked`` event)
    with the session when one is given."""
    state = request.app.state
    session = await run_in_threadpool(read, state, _session, session_id)
    if session_id is not None and (session is None or session.booth != booth):
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"No session {session_id} on {booth}.")
    telemetry, age = worker_link.latest_telemetry(worker_link.bridge_of(state), booth)
    if age is None or age > health.STALE_AFTER_SECONDS:
        telemetry = None
    spoken = await say_test_prompt(state, booth) if say and telemetry is not None else None
    result = check.run(telemetry, display_presence(state, booth), settings.data_dir,
                       settings.session_disk_bytes, spoken)  # fmt: skip
    event_id = await run_in_threadpool(write, state, store, booth, session, result)
    return {"event_id": event_id, "booth": booth, **result}


def _session(db: DbSession, session_id: int | None) -> Session | None:
    if session_id is None:
        return None
    found = db.get(Session, session_id)
    if found is not None:
        db.expunge(found)
    return found
