"""Flags about how far a session got and whether it counts, beside :mod:`.flags`:

- not_started: registered, the session was never started;
- ended_early: the wizard ended the session early (reason, where, what did not run);
- partial: an interaction of a session that is no longer running stopped half-way (how
  many suggestions were decided, whether the questionnaire was answered);
- excluded: the PI left the participant out of the analysis (reason);
- not_voiced: a prompt the robot did not speak (the display or robot reported it not
  played: ``prompt.not_voiced``, ``prompt.not_played``, or ``prompt.speech_end`` with a
  reason such as ``autoplay_blocked``);
- typed_speech: the wizard typed a sentence for the robot because no prompt fitted (a
  deviation from the scripted prompts, with its text);
- recording: the interaction's face recording failed (``recording.failed``: read-only
  folder, full disk), or never started because the worker refused it; one flag per
  interaction, with the first reason.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.queries import decisions, interaction_status, recording_failure
from chameleons.backend.models import Event, Interaction, Participant, Session
from chameleons.backend.sessions.states import END_REASONS

NOT_VOICED_KINDS = frozenset({"prompt.not_voiced", "prompt.not_played"})
AddFlag = Callable[[int, str, int | None, str, int | None], None]


def run_flags(
    db: DbSession,
    sessions: list[Session],
    interactions: list[Interaction],
    events: list[Event],
    suggestions_per_interaction: int,
    add: AddFlag,
) -> None:
    participants = {
        p.id: p
        for p in db.scalars(
            select(Participant).where(Participant.id.in_({s.participant_id for s in sessions}))
        )
    }
    by_session: dict[int, list[Interaction]] = {}
    for interaction in sorted(interactions, key=lambda i: i.position):
        by_session.setdefault(interaction.session_id, []).append(interaction)
    counts = decisions(db, [i.id for i in interactions])
    for session in sessions:
        own = by_session.get(session.id, [])
        participant = participants.get(session.participant_id)
        if session.state == "pending":
            add(session.id, "not_started", None, "registered; the session was never started", None)
        if session.state == "ended":
            add(session.id, "ended_early", _where(own), _ended_text(session, own), None)
        if session.state in ("ended", "complete"):
            for interaction in own:
                if interaction_status(interaction) == "partial":
                    decided = counts[interaction.id].decided
                    text = (
                        f"interaction {interaction.position}: stopped in {interaction.state}, "
                        f"{decided} of {suggestions_per_interaction} suggestions decided"
                    )
                    add(session.id, "partial", interaction.position, text, None)
        if participant is not None and participant.excluded_at is not None:
            text = f"excluded from the analysis: {participant.exclusion_reason}"
            add(session.id, "excluded", None, text, None)
    _not_voiced(events, {i.id: i.position for i in interactions}, add)
    _typed_speech(events, add)
    _recording(events, {i.id: i.position for i in interactions}, add)


def _recording(events: list[Event], positions: dict[int, int], add: AddFlag) -> None:
    seen: set[int] = set()
    for event in events:
        reason = recording_failure(event)
        if reason is None or event.session_id is None or event.interaction_id in seen:
            continue
        seen.add(event.interaction_id or -1)
        position = positions.get(event.interaction_id or -1)
        where = f"interaction {position}" if position else "session"
        add(event.session_id, "recording", position, f"{where}: not recorded: {reason}", event.id)


def _typed_speech(events: list[Event], add: AddFlag) -> None:
    for event in events:
        if event.kind != "wizard.typed_speech" or event.session_id is None:
            continue
        payload: dict[str, Any] = event.payload or {}
        position = payload.get("position")
        where = f"interaction {position}" if position else "session"
        add(event.session_id, "typed_speech", position,
            f"{where}: the robot said a typed sentence: \"{payload.get('text', '')}\"",
            event.id)  # fmt: skip


def _where(interactions: list[Interaction]) -> int | None:
    started = [i for i in interactions if interaction_status(i) != "not_run"]
    return started[-1].position if started else None


def _ended_text(session: Session, interactions: list[Interaction]) -> str:
    reason = END_REASONS.get(session.end_reason or "", session.end_reason or "no reason")
    note = f" ({session.end_note})" if session.end_note else ""
    where = _where(interactions)
    not_run = [str(i.position) for i in interactions if interaction_status(i) == "not_run"]
    text = f"ended early{f' during interaction {where}' if where else ''}: {reason}{note}"
    if not_run:
        text += f"; interaction{'s' if len(not_run) > 1 else ''} {', '.join(not_run)} not run"
    return text


def _not_voiced(events: list[Event], positions: dict[int, int], add: AddFlag) -> None:
    for event in events:
        payload: dict[str, Any] = event.payload or {}
        silent = event.kind in NOT_VOICED_KINDS or (
            event.kind == "prompt.speech_end" and bool(payload.get("reason"))
        )
        if not silent or event.session_id is None:
            continue
        position = positions.get(event.interaction_id or -1) or payload.get("position")
        what = payload.get("detail") or payload.get("reason") or "not played"
        prompt = payload.get("prompt_id") or payload.get("group") or "a prompt"
        where = f"interaction {position}" if position else "session"
        add(event.session_id, "not_voiced", position, f"{where}: {prompt} not voiced ({what})",
            event.id)  # fmt: skip
