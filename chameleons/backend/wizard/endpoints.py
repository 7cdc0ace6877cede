"""The wizard console's JSON API: its state, the prompt buttons, play and stop.

Session changes (start, advance, decide, undo, condition switch) are the session flow's
own endpoints; the console calls those directly.
"""

from __future__ import annotations

from typing import Any

from fastapi import Depends, HTTPException, Query, Request, status
from pydantic import BaseModel, Field, field_validator

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentStaff
from chameleons.backend.booth.behaviour import demo_clip_warning
from chameleons.backend.dependencies import DbSession
from chameleons.backend.routing import make_router
from chameleons.backend.studies.errors import http_errors
from chameleons.backend.wizard import capture, layout, playback, repository, robot, typed_speech
from chameleons.backend.wizard.catalogues import (
    MissingCatalogueError,
    catalogue_for,
    missing_in_language,
)
from chameleons.backend.wizard.console_state import console_state

router = make_router(prefix="/api/wizard", tags=["wizard"])
WRITE = [Depends(verify_csrf)]


class PlayRequest(BaseModel):
    group: str = Field(min_length=1, max_length=128, description="the prompt's variant group")


def _view(db: DbSession, session_id: int) -> repository.SessionView:
    try:
        return repository.load_session(db, session_id)
    except repository.SessionNotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from None


@router.get("/sessions")
def list_sessions(_user: CurrentStaff, db: DbSession) -> list[dict[str, Any]]:
    """Recent sessions, newest first, for the console's session picker."""
    return [
        {
            "id": session.id,
            "participant": person.code,
            "state": session.state,
            "booth": session.booth,
            "current_position": session.current_position,
            "rehearsal": session.is_rehearsal,
            "created_at": session.created_at.isoformat(),
        }
        for session, person in repository.recent_sessions(db)
    ]


@router.get("/sessions/{session_id}/console")
def get_console(
    session_id: int, request: Request, _user: CurrentStaff, db: DbSession
) -> dict[str, Any]:
    """The session flow's snapshot plus the console's timeline and suggestion prompts."""
    with http_errors():
        return console_state(db, request.app.state, session_id, base_url(request))


def base_url(request: Request) -> str:
    configured = request.app.state.settings.public_url
    return str(configured or request.base_url).rstrip("/")


@router.get("/sessions/{session_id}/prompts")
def get_prompts(
    session_id: int,
    request: Request,
    _user: CurrentStaff,
    db: DbSession,
    position: int | None = Query(default=None, ge=1),
) -> dict[str, Any]:
    """The prompt buttons of an interaction (default: the current one), grouped by stage,
    items in the order the participant was shown them, with their keyboard shortcuts."""
    view = _view(db, session_id)
    interaction = view.at(position) if position is not None else view.current
    if interaction is None:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND, f"Session {session_id} has no such interaction."
        )
    language = view.session.language
    try:
        catalogue = catalogue_for(request.app.state, interaction.actor, language)
        missing = missing_in_language(request.app.state, interaction.actor, language)
    except MissingCatalogueError as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None
    facts = layout.InteractionFacts(
        task=interaction.task,
        items=list(interaction.presented_order),
        item_names=view.item_names(interaction),
        robot_name=interaction.robot_name,
    )
    return {
        "position": interaction.position,
        "actor": interaction.actor,
        "actor_name": catalogue.profile.display_name,
        "sections": layout.sections(catalogue, facts),
        # The session's language: only its prompts are offered; these have no recording.
        "language": language,
        "missing": missing,
        # Before the robot shows the condition to a real participant: what is not for them.
        "warnings": _interaction_warnings(request.app.state, view, interaction.condition),
    }


def _interaction_warnings(state: Any, view: repository.SessionView, condition: str) -> list[str]:
    """The synthetic demo clip a real participant's natural condition would replay."""
    if view.session.is_rehearsal:
        return []
    warning = demo_clip_warning(state, view.spec, [condition])
    return [warning] if warning else []


@router.post("/sessions/{session_id}/prompts/play", dependencies=WRITE)
async def play_prompt(
    session_id: int, data: PlayRequest, request: Request, _user: CurrentStaff
) -> dict[str, Any]:
    """Play a random variant of the group (never the one played last). Answers once the
    worker acknowledged or failed to; ``sent`` false says why (the play is logged anyway)."""
    with http_errors():
        return await playback.play(request.app.state, session_id, data.group)


class SayRequest(BaseModel):
    text: str = Field(min_length=1, max_length=typed_speech.MAX_TEXT,
                      description="what the robot says, in the actor's voice")  # fmt: skip

    @field_validator("text")
    @classmethod
    def _sayable(cls, text: str) -> str:
        text = " ".join(text.split())
        if not text:
            raise ValueError("Type what the robot should say first.")
        return text


@router.post("/sessions/{session_id}/prompts/say", dependencies=WRITE)
async def say_typed(
    session_id: int, data: SayRequest, request: Request, _user: CurrentStaff
) -> dict[str, Any]:
    """Speech fallback: the robot says the typed sentence (logged as a deviation)."""
    with http_errors():
        return await playback.say(request.app.state, session_id, data.text)


@router.post("/sessions/{session_id}/prompts/stop", dependencies=WRITE)
async def stop_prompt(session_id: int, request: Request, _user: CurrentStaff) -> dict[str, Any]:
    with http_errors():
        return await playback.stop(request.app.state, session_id)


@router.post("/sessions/{session_id}/robot/apply", dependencies=WRITE)
async def apply_to_robot(session_id: int, request: Request, _user: CurrentStaff) -> dict[str, Any]:
    """Send the current interaction's condition (behaviour) and face to the booth's worker;
    logged as ``robot.applied`` or, with the reasons, ``robot.not_applied``."""
    with http_errors():
        return await robot.apply(request.app.state, session_id)


@router.post("/sessions/{session_id}/capture/reset-pairing", dependencies=WRITE)
async def reset_capture_pairing(
    session_id: int, request: Request, _user: CurrentStaff
) -> dict[str, Any]:
    """Let the booth's face capture pair with the next phone that sends (the worker accepts
    one phone only); logged as ``capture.pairing_reset``."""
    with http_errors():
        return await capture.reset_pairing(request.app.state, session_id)


@router.post("/sessions/{session_id}/robot/retry", dependencies=WRITE)
async def retry_robot(session_id: int, request: Request, _user: CurrentStaff) -> dict[str, Any]:
    """Ask the booth's worker to try the robot again after a refused or unanswered login."""
    with http_errors():
        return await robot.retry(request.app.state, session_id)
