"""Excluding a participant (kept, left out of the analysis) and handing a dropout's plan row
to a replacement. Flushes only; every change is an event in the participant's timeline.

Excluding records the reason and time on the participant; including again clears them (the
events keep the history). Handing the row on frees it (the participant's session keeps
naming the row it ran), counts a dropout on the row, and the next participant registered
gets that row first, so the completed rows stay a prefix of the plan.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.events import repository as events
from chameleons.backend.models import Participant, PlanRow, Session
from chameleons.backend.studies.errors import ConflictError, InvalidInputError, NotFoundError

MAX_REASON = 500
EXCLUDED = "participant.excluded"
INCLUDED = "participant.included"
ROW_RELEASED = "plan_row.handed_on"


@dataclass(frozen=True)
class Released:
    participant: str
    row_number: int


def find(db: DbSession, study_id: int, code: str) -> Participant:
    participant = db.scalars(
        select(Participant).where(Participant.study_id == study_id, Participant.code == code)
    ).first()
    if participant is None:
        raise NotFoundError(f"There is no participant {code!r} in this study.")
    return participant


def sessions_of(db: DbSession, participant: Participant) -> list[Session]:
    query = select(Session).where(Session.participant_id == participant.id).order_by(Session.id)
    return list(db.scalars(query))


def exclude(db: DbSession, study_id: int, code: str, reason: str) -> Participant:
    reason = reason.strip()
    if not reason:
        raise InvalidInputError("Give the reason for excluding the participant.")
    if len(reason) > MAX_REASON:
        raise InvalidInputError(f"The reason is longer than {MAX_REASON} characters.")
    participant = find(db, study_id, code)
    if participant.excluded_at is not None:
        raise ConflictError(f"{code} is already excluded ({participant.exclusion_reason}).")
    participant.excluded_at = datetime.now(UTC)
    participant.exclusion_reason = reason
    db.flush()
    _log(db, participant, EXCLUDED, {"participant": code, "reason": reason})
    return participant


def include(db: DbSession, study_id: int, code: str) -> Participant:
    participant = find(db, study_id, code)
    if participant.excluded_at is None:
        raise ConflictError(f"{code} is not excluded.")
    before = participant.exclusion_reason
    participant.excluded_at = None
    participant.exclusion_reason = None
    db.flush()
    _log(db, participant, INCLUDED, {"participant": code, "was_excluded_for": before})
    return participant


def can_hand_on(db: DbSession, participant: Participant) -> str | None:
    """Why the participant's row cannot go to a replacement (None: it can)."""
    if participant.plan_row_id is None:
        return f"{participant.code} holds no plan row."
    sessions = sessions_of(db, participant)
    states = {s.state for s in sessions}
    if states & {"running", "final_questionnaire"}:
        return f"{participant.code}'s session is still running: end it first."
    complete = "complete" in states
    if complete and participant.excluded_at is None:
        return (
            f"{participant.code} completed the study; exclude them first if their row should "
            "go to a replacement."
        )
    return None


def hand_on_row(db: DbSession, study_id: int, code: str) -> Released:
    """Free the participant's plan row for the next participant (their data stay)."""
    participant = find(db, study_id, code)
    why_not = can_hand_on(db, participant)
    if why_not:
        raise ConflictError(why_not)
    row = db.get(PlanRow, participant.plan_row_id)
    if row is None:
        raise NotFoundError(f"{code}'s plan row no longer exists.")
    participant.plan_row_id = None
    row.dropouts += 1
    db.flush()
    _log(
        db,
        participant,
        ROW_RELEASED,
        {"participant": code, "row_number": row.row_number, "dropouts": row.dropouts},
    )
    return Released(code, row.row_number)


def _log(db: DbSession, participant: Participant, kind: str, payload: dict[str, object]) -> None:
    """In the timeline of each of the participant's sessions (else the study's)."""
    session_ids: list[int | None] = [s.id for s in sessions_of(db, participant)]
    for session_id in session_ids or [None]:
        events.record(
            db, kind, source="pi", study_id=participant.study_id, session_id=session_id,
            payload=payload,
        )  # fmt: skip
