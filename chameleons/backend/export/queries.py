"""Queries shared by the export tables, the scores and the dashboard, and the rules that
turn what was recorded into measures: an interaction that never ran, or whose suggestions
were not all decided, has no ``accepted`` count (missing, never 0)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sqlalchemy import ColumnElement, Select, false, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import Event, Interaction, Participant, Session, Suggestion

BATCH = 1000


def session_filter(study_id: int, include_rehearsal: bool) -> list[ColumnElement[bool]]:
    """WHERE clauses for a query joined to Session and Participant."""
    clauses: list[ColumnElement[bool]] = [Session.study_id == study_id]
    if not include_rehearsal:
        clauses += [Session.is_rehearsal == false(), Participant.is_rehearsal == false()]
    return clauses


def joined(query: Select[Any], study_id: int, include_rehearsal: bool) -> Select[Any]:
    return query.join(Participant, Participant.id == Session.participant_id).where(
        *session_filter(study_id, include_rehearsal)
    )


INTERACTION_STATUSES = ("complete", "partial", "not_run")
SESSION_STATUSES = ("complete", "in_progress", "not_started", "ended_early")


@dataclass(frozen=True)
class Decisions:
    decided: int
    accepted: int


@dataclass(frozen=True)
class InteractionRecord:
    """A counted interaction with its session, participant and suggestion decisions."""

    interaction: Interaction
    session: Session
    participant: Participant
    decisions: Decisions

    @property
    def code(self) -> str:
        return self.participant.code

    def accepted(self, suggestions: int) -> int | None:
        """Accepted suggestions, only when all ``suggestions`` were decided (else missing)."""
        return self.decisions.accepted if self.decisions.decided >= suggestions else None

    @property
    def status(self) -> str:
        return interaction_status(self.interaction)


def interaction_status(interaction: Interaction) -> str:
    """complete (all steps done), partial (started, not finished) or not_run."""
    if interaction.state == "done":
        return "complete"
    if interaction.state == "pending" and interaction.started_at is None:
        return "not_run"
    return "partial"


def session_status(session: Session) -> str:
    if session.state == "complete":
        return "complete"
    if session.state == "ended":
        return "ended_early"
    if session.state == "pending":
        return "not_started"
    return "in_progress"


def decisions(db: DbSession, interaction_ids: list[int]) -> dict[int, Decisions]:
    """Per interaction: how many suggestions were decided, and how many of them accepted."""
    decided = dict.fromkeys(interaction_ids, 0)
    accepted = dict.fromkeys(interaction_ids, 0)
    if interaction_ids:
        query = select(Suggestion.interaction_id, Suggestion.accepted).where(
            Suggestion.interaction_id.in_(interaction_ids), Suggestion.accepted.is_not(None)
        )
        for interaction_id, was_accepted in db.execute(query):
            decided[interaction_id] += 1
            accepted[interaction_id] += int(bool(was_accepted))
    return {i: Decisions(decided[i], accepted[i]) for i in interaction_ids}


def counted_interactions(
    db: DbSession, study_id: int, include_rehearsal: bool
) -> list[InteractionRecord]:
    """The counted interactions, in participant code / session / position order."""
    query = select(Interaction, Session, Participant).join(
        Session, Session.id == Interaction.session_id
    )
    query = joined(query, study_id, include_rehearsal).order_by(
        Participant.code, Session.id, Interaction.position
    )
    found = list(db.execute(query).tuples())
    counts = decisions(db, [interaction.id for interaction, _, _ in found])
    return [
        InteractionRecord(interaction, session, participant, counts[interaction.id])
        for interaction, session, participant in found
    ]


RECORDING_FAILED = "recording.failed"


def recording_failure(event: Event) -> str | None:
    """The sentence of a failed recording, for an event that tells one (else None)."""
    payload: dict[str, Any] = event.payload or {}
    if event.kind == RECORDING_FAILED:
        return str(payload.get("reason") or "the recording failed")
    if event.kind == "recording.not_started" and payload.get("reason") == "recording_failed":
        return str(payload.get("detail") or "the recording did not start")
    return None


def recording_problems(db: DbSession, study_id: int) -> dict[int, str]:
    """Interaction id -> the first reason its recording failed, for one study."""
    query = (
        select(Event)
        .join(Session, Session.id == Event.session_id)
        .where(Session.study_id == study_id,
               Event.kind.in_([RECORDING_FAILED, "recording.not_started"]),
               Event.interaction_id.is_not(None))
        .order_by(Event.id)
    )  # fmt: skip
    found: dict[int, str] = {}
    for event in db.scalars(query):
        reason = recording_failure(event)
        if reason is not None and event.interaction_id is not None:
            found.setdefault(event.interaction_id, reason)
    return found
