"""The booth check's page and API: ``GET /booths/<booth>/check`` (staff),
``GET /api/booths/<booth>/check`` (what the check will ask for: the head movement's prompts
and the copy delay) and ``POST /api/booths/<booth>/check`` (runs the check, logs
``booth.checked``)."""

from __future__ import annotations

import time
from typing import Annotated, Any

from fastapi import Depends, HTTPException, Path, Query, Request, status
from fastapi.responses import HTMLResponse, Response
from sqlalchemy.orm import Session as DbSession
from starlette.concurrency import run_in_threadpool

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentStaff
from chameleons.backend.booth import check, check_robot, check_run
from chameleons.backend.booth.check_store import store
from chameleons.backend.booth.speech_test import say_test_prompt
from chameleons.backend.capture.links import capture_url, request_base
from chameleons.backend.dependencies import AppSettings, Templates
from chameleons.backend.models import Session
from chameleons.backend.routing import make_router
from chameleons.backend.wizard import health, worker_link
from chameleons.backend.wizard.live import display_paint_rate, display_presence
from chameleons.backend.wizard.pages import BOOTH_PATTERN
from chameleons.backend.wizard.playback import read, write

router = make_router(tags=["booth"])
Booth = Annotated[str, Path(pattern=BOOTH_PATTERN)]
SessionId = Annotated[int | None, Query(description="Store the check with this session.")]
CONDITION_HELP = "Check this copy condition of the study (default: its first)."
ConditionId = Annotated[str | None, Query(max_length=64, description=CONDITION_HELP)]


@router.get("/booths/{booth}/check", response_class=HTMLResponse)
def check_page(
    request: Request, booth: Booth, user: CurrentStaff, templates: Templates,
    settings: AppSettings, session_id: SessionId = None, condition: ConditionId = None,
) -> Response:  # fmt: skip
    plan = _plan(request.app.state, booth, session_id, settings, condition)
    context = {"user": user, "booth": booth, "session_id": session_id, "plan": plan.describe(),
               "expected_head": check.expected_head(),
               "capture_url": capture_url(request.app, booth, request_base(request))}  # fmt: skip
    return templates.TemplateResponse(request, "booth/check.html", context)


@router.get("/api/booths/{booth}/check")
def check_plan(
    request: Request, booth: Booth, _user: CurrentStaff, settings: AppSettings,
    session_id: SessionId = None, condition: ConditionId = None,
) -> dict[str, Any]:  # fmt: skip
    """What the check asks the technician to do and for how long, and the copy condition
    it runs (its params and their words, and the study's other copy conditions)."""
    plan = _plan(request.app.state, booth, session_id, settings, condition)
    return {"booth": booth, **plan.describe(), "expected_head": check.expected_head()}


@router.post("/api/booths/{booth}/check", dependencies=[Depends(verify_csrf)])
async def run_check(
    request: Request, booth: Booth, _user: CurrentStaff, settings: AppSettings,
    session_id: SessionId = None, condition: ConditionId = None,
    say: Annotated[bool, Query(description="Play the test prompt (speech step).")] = True,
    movement: Annotated[bool, Query(description="Run the robot in copy for the head "
                                    "movement (without it the copy step fails).")] = True,
) -> dict[str, Any]:  # fmt: skip
    """Judge every step; stored as a ``booth_check`` row (and ``booth.checked`` event) with
    the session when one is given. Refused (409) while an interaction runs on the booth."""
    state = request.app.state
    session = await run_in_threadpool(read, state, _session, session_id)
    if session_id is not None and (session is None or session.booth != booth):
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"No session {session_id} on {booth}.")
    refused = await run_in_threadpool(read, state, check_run.refusal, booth)
    if refused is not None:
        raise HTTPException(status.HTTP_409_CONFLICT, refused)
    try:
        plan = await run_in_threadpool(read, state, check_run.plan_for, booth, session, settings,
                                       condition)  # fmt: skip
    except ValueError as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from None
    try:
        async with check_run.exclusive(state, booth):
            result = await _judge(state, booth, plan, settings, say=say, movement=movement)
    except check_run.CheckRefusedError as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None
    event_id = await run_in_threadpool(write, state, store, booth, session, result, plan.study_id)
    return {"event_id": event_id, "booth": booth, **result}


async def _judge(
    state: Any, booth: str, plan: check_run.Plan, settings: Any, *, say: bool, movement: bool
) -> dict[str, Any]:
    """The steps, with the head movement, the copy and the test prompt on the condition's
    robot (:mod:`.check_robot`: a booth with both robots is put on it and back)."""
    started = time.monotonic()  # the display's paint rate is judged over the check's run
    telemetry = _fresh_telemetry(state, booth)
    if telemetry is None:
        return check.run(None, display_presence(state, booth), settings.data_dir,
                         settings.session_disk_bytes)  # fmt: skip
    moved = spoken = None
    async with check_robot.on_robot(state, booth, plan.renderer, plan.condition,
                                    plan.face) as checked:  # fmt: skip
        if checked.problem is not None:  # a sentence, at once: nothing is driven
            moved = plan.movement(robot=checked.words, unreachable=checked.problem)
            spoken = {"prompt_id": None, "start_ms": None, "ended": False,
                      "problem": f"not run: {checked.problem}"} if say else None  # fmt: skip
        else:
            if movement:
                moved = await check_run.exercise(state, booth, plan, telemetry, checked.words)
            spoken = await say_test_prompt(state, booth) if say else None
        telemetry = _fresh_telemetry(state, booth)
    return check.run(telemetry, display_presence(state, booth), settings.data_dir,
                     settings.session_disk_bytes, spoken, moved, checked.describe(),
                     paint_fps=display_paint_rate(state, booth, started))  # fmt: skip


def _fresh_telemetry(state: Any, booth: str) -> dict[str, Any] | None:
    telemetry, age = worker_link.latest_telemetry(worker_link.bridge_of(state), booth)
    return telemetry if age is not None and age <= health.STALE_AFTER_SECONDS else None


def _plan(
    state: Any, booth: str, session_id: int | None, settings: Any, condition: str | None
) -> check_run.Plan:
    session = read(state, _session, session_id)
    if session_id is not None and (session is None or session.booth != booth):
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"No session {session_id} on {booth}.")
    try:
        return read(state, check_run.plan_for, booth, session, settings, condition)
    except ValueError as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from None


def _session(db: DbSession, session_id: int | None) -> Session | None:
    if session_id is None:
        return None
    found = db.get(Session, session_id)
    if found is not None:
        db.expunge(found)
    return found
