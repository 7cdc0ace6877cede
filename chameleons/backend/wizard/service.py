"""Playing and stopping prompts: the database side (choose the variant, log every step).

Flushes only; the caller's write scope commits (and then publishes the events live). The
timeline of one play: ``prompt.played`` (the wizard's click, server time) ->
``prompt.acked`` with the click->ack latency, or ``prompt.not_sent`` with the reason ->
``prompt.speech_start`` with the worker's timestamp and the click->speech latency ->
``prompt.speech_end``.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy.orm import Session

from chameleons.backend.display.channel import DISPLAY_CLOSED
from chameleons.backend.events import repository as events
from chameleons.backend.models import Event
from chameleons.backend.models.base import utcnow
from chameleons.backend.studies.errors import ConflictError, NotFoundError
from chameleons.backend.wizard import repository
from chameleons.backend.wizard.catalogues import MissingCatalogueError, catalogue_for
from chameleons.prompts import Catalogue, Prompt, pick_variant

ACKED = "prompt.acked"
NOT_SENT = "prompt.not_sent"
SPEECH_START = "prompt.speech_start"
SPEECH_END = "prompt.speech_end"
NOT_VOICED = "prompt.not_voiced"  # sent, acknowledged, and no robot voiced it
# The robot display went while it played (the display channel reports the end for it,
# DISPLAY_CLOSED): a reason on the play's speech end, so the play counts as not voiced.
REASON_DETAILS = {DISPLAY_CLOSED: "the robot display was closed while it played"}
STOPPED = "prompt.stopped"


@dataclass(frozen=True)
class Cue:
    """One play, as decided and logged at the click."""

    event_id: int
    study_id: int
    session_id: int
    interaction_id: int
    booth: str
    actor: str
    prompt: Prompt
    duration: float
    clicked_at: datetime
    audio: str | None
    lipsync: str | None
    # The language folder the prompt's catalogue lies in (None: the actor's own folder):
    # the audio URL must name it, or the robot is served the main language's recording.
    language_folder: str | None = None

    def summary(self) -> dict[str, Any]:
        return {
            "event_id": self.event_id,
            "prompt_id": self.prompt.id,
            "group": self.prompt.group,
            "text": self.prompt.text,
            "duration": self.duration,
            "clicked_at": self.clicked_at.isoformat(),
        }


@dataclass(frozen=True)
class Outcome:
    """What the worker said (or why nothing was said)."""

    sent: bool
    reason: str = ""
    detail: str = ""
    result: dict[str, Any] | None = None


def start_play(
    db: Session, state: Any, session_id: int, group_name: str, rng: random.Random | None = None
) -> Cue:
    """Pick a variant of ``group_name`` (never the one played last) and log the click."""
    clicked_at = utcnow()
    view = speaking(db, session_id)
    interaction = view.current
    if interaction is None:
        raise ConflictError("This session has no current interaction to play prompts in.")
    catalogue = _catalogue(state, interaction.actor, view.session.language)
    try:
        group = catalogue.group(group_name)
    except KeyError:
        raise NotFoundError(
            f"Actor {interaction.actor!r} has no prompt group {group_name!r}"
            f" in {view.session.language}."
        ) from None
    last = repository.last_played_variant(db, session_id, group_name)
    prompt = pick_variant(group, last, rng)
    duration = round(catalogue.duration(prompt), 2)
    event = events.record(
        db,
        repository.PLAYED,
        source="wizard",
        study_id=view.session.study_id,
        session_id=session_id,
        interaction_id=interaction.id,
        at=clicked_at,
        payload={
            "prompt_id": prompt.id,
            "group": prompt.group,
            "stage": prompt.stage.value,
            "item": prompt.item,
            "other_item": prompt.other_item,
            "text": prompt.text,
            "duration": duration,
            "has_audio": prompt.audio is not None,
            "actor": interaction.actor,
            "position": interaction.position,
        },
    )
    return Cue(
        event_id=event.id,
        study_id=view.session.study_id,
        session_id=session_id,
        interaction_id=interaction.id,
        booth=view.session.booth,
        actor=interaction.actor,
        prompt=prompt,
        duration=duration,
        clicked_at=clicked_at,
        audio=str(prompt.audio) if prompt.audio else None,
        lipsync=str(catalogue.lipsync_file(prompt)) if prompt.lipsync else None,
        language_folder=catalogue.language_folder,
    )


def record_outcome(db: Session, cue: Cue, outcome: Outcome, acked_at: datetime) -> Event:
    """Log the worker's acknowledgement (with the click->ack latency) or why it was not sent."""
    payload: dict[str, Any] = {"prompt_id": cue.prompt.id, "play_event_id": cue.event_id}
    if outcome.sent:
        payload["click_to_ack_ms"] = _ms_between(cue.clicked_at, acked_at)
        payload["result"] = outcome.result or {}
        kind, source = ACKED, "worker"
    else:
        payload.update(reason=outcome.reason, detail=outcome.detail)
        kind, source = NOT_SENT, "server"
    return _log(db, cue, kind, source, payload, at=acked_at)


def record_speech(
    db: Session, cue: Cue, started: bool, received_at: datetime, worker_time: float | None,
    outcome: str | None = None, reason: str | None = None,
) -> Event:  # fmt: skip
    """Log a speech start/end the worker reported for this play; an end says how it ended
    (``played``, ``interrupted`` by the next prompt, ``stopped`` by the wizard) and, when
    the participant did not hear it to its end, why (``reason``: ``display_closed``)."""
    payload: dict[str, Any] = {"prompt_id": cue.prompt.id, "play_event_id": cue.event_id}
    if started:
        payload["click_to_speech_ms"] = _ms_between(cue.clicked_at, received_at)
    elif outcome:
        payload["outcome"] = outcome
    if not started and reason:
        payload.update(reason=reason, detail=REASON_DETAILS.get(reason, reason))
    kind = SPEECH_START if started else SPEECH_END
    return _log(db, cue, kind, "worker", payload, at=received_at, worker_time=worker_time)


def record_not_voiced(db: Session, cue: Cue, detail: str, received_at: datetime) -> Event:
    """Log that no robot voiced this play (NOT VOICED; a data-quality flag)."""
    payload = {"prompt_id": cue.prompt.id, "play_event_id": cue.event_id, "detail": detail}
    return _log(db, cue, NOT_VOICED, "server", payload, at=received_at)


def record_display_failure(
    db: Session, cue: Cue, reason: str, detail: str, received_at: datetime
) -> Event:
    """Log the end of a play the robot display could not start (e.g. ``autoplay_blocked``)."""
    payload = {"prompt_id": cue.prompt.id, "play_event_id": cue.event_id, "reason": reason,
               "detail": detail}  # fmt: skip
    return _log(db, cue, SPEECH_END, "display", payload, at=received_at)


def record_stop(db: Session, session_id: int, outcome: Outcome) -> Event:
    view = _running(db, session_id)
    last = repository.last_played(db, session_id)
    current = view.current
    payload: dict[str, Any] = {
        "prompt_id": last.payload.get("prompt_id") if last else None,
        "play_event_id": last.id if last else None,
        "sent": outcome.sent,
    }
    if not outcome.sent:
        payload.update(reason=outcome.reason, detail=outcome.detail)
    return events.record(
        db,
        STOPPED,
        source="wizard",
        study_id=view.session.study_id,
        session_id=session_id,
        interaction_id=current.id if current else None,
        payload=payload,
    )


def booth_of(db: Session, session_id: int) -> str:
    return _running(db, session_id).session.booth


def _running(db: Session, session_id: int) -> repository.SessionView:
    try:
        view = repository.load_session(db, session_id)
    except repository.SessionNotFoundError as exc:
        raise NotFoundError(str(exc)) from None
    if view.session.state in ("complete", "ended"):
        raise ConflictError(
            f"Session {session_id} is {view.session.state}; nothing more is played."
        )
    return view


def speaking(db: Session, session_id: int) -> repository.SessionView:
    """The session for a prompt or typed sentence: refused while paused (prompts are off)."""
    view = _running(db, session_id)
    if view.session.paused_at is not None:
        raise ConflictError(
            f"Session {session_id} is paused: prompts are off until the wizard resumes it."
        )
    return view


def _catalogue(state: Any, actor: str, language: str | None = None) -> Catalogue:
    try:
        return catalogue_for(state, actor, language)
    except MissingCatalogueError as exc:
        raise ConflictError(str(exc)) from None


def _log(
    db: Session,
    cue: Cue,
    kind: str,
    source: str,
    payload: dict[str, Any],
    *,
    at: datetime,
    worker_time: float | None = None,
) -> Event:
    return events.record(
        db,
        kind,
        source=source,
        study_id=cue.study_id,
        session_id=cue.session_id,
        interaction_id=cue.interaction_id,
        payload=payload,
        worker_time=worker_time,
        at=at,
    )


def _ms_between(start: datetime, end: datetime) -> float:
    return round((end - start).total_seconds() * 1000, 1)
