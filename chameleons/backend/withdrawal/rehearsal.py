"""Marking a participant's sessions as rehearsals (staff practice runs) and back.

Rehearsals are left out of balance tables, exports and analysis unless asked for. A
rehearsal holds no plan row (the session flow registers rehearsals without one), so
marking a participant as rehearsal frees their row for a real participant; unmarking
takes the row back only while it is still free.
"""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.events import repository as events
from chameleons.backend.models import Participant, PlanRow, Session
from chameleons.backend.withdrawal.service import WithdrawalError, find_participant


class RehearsalError(WithdrawalError):
    pass


def set_rehearsal(db: DbSession, study_id: int, code: str, rehearsal: bool) -> Participant:
    participant = find_participant(db, study_id, code)
    sessions = list(db.scalars(select(Session).where(Session.participant_id == participant.id)))
    if rehearsal:
        participant.plan_row_id = None
    elif participant.plan_row_id is None and sessions:
        participant.plan_row_id = _reclaim_row(db, sessions[-1].plan_row_id)
    participant.is_rehearsal = rehearsal
    for session in sessions:
        session.is_rehearsal = rehearsal
        # Recorded as every event is: an open console hears it (and shows the rehearsal
        # tag) as soon as the change commits.
        events.record(
            db,
            "session.rehearsal_marked" if rehearsal else "session.rehearsal_unmarked",
            source="pi",
            study_id=study_id,
            session_id=session.id,
        )
    db.flush()
    return participant


def _reclaim_row(db: DbSession, plan_row_id: int) -> int:
    holder = db.scalars(select(Participant).where(Participant.plan_row_id == plan_row_id)).first()
    if holder is not None:
        row = db.get(PlanRow, plan_row_id)
        number = row.row_number if row else plan_row_id
        raise RehearsalError(
            f"Plan row {number} now belongs to {holder.code}; this participant stays a rehearsal."
        )
    return plan_row_id
