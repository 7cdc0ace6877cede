"""Which study and which sessions an export, a balance table or an analysis covers.

Rehearsals (a rehearsal participant, or a session marked as one) never count unless the
caller asks for them; every reader of study data goes through :func:`counted_sessions`.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import Participant, Session, Study


class StudyNotFoundError(LookupError):
    """No study with that id, or no study at all."""


@dataclass(frozen=True)
class SessionInfo:
    """A counted session with its participant, as the exports and the analysis see it."""

    session_id: int
    participant_id: int
    participant_code: str
    plan_row_id: int
    is_rehearsal: bool


def resolve_study(db: DbSession, study_id: int | None = None) -> Study:
    """The given study, or else the newest active one (then the newest of any)."""
    if study_id is not None:
        study = db.get(Study, study_id)
        if study is None:
            raise StudyNotFoundError(f"there is no study with id {study_id}")
        return study
    newest = select(Study).order_by(Study.is_active.desc(), Study.id.desc()).limit(1)
    found = db.scalars(newest).first()
    if found is None:
        raise StudyNotFoundError("there is no study yet: create one first")
    return found


def counted_sessions(
    db: DbSession, study_id: int, include_rehearsal: bool = False
) -> list[SessionInfo]:
    """The study's sessions in participant-code order, rehearsals left out unless asked."""
    query = (
        select(Session, Participant)
        .join(Participant, Participant.id == Session.participant_id)
        .where(Session.study_id == study_id)
        .order_by(Participant.code, Session.id)
    )
    sessions = []
    for session, participant in db.execute(query):
        rehearsal = session.is_rehearsal or participant.is_rehearsal
        if rehearsal and not include_rehearsal:
            continue
        sessions.append(
            SessionInfo(
                session.id, participant.id, participant.code, session.plan_row_id, rehearsal
            )
        )
    return sessions


def as_utc(moment: datetime | None) -> datetime | None:
    """SQLite hands back naive datetimes; everything is stored in UTC."""
    if moment is None:
        return None
    return moment.replace(tzinfo=UTC) if moment.tzinfo is None else moment.astimezone(UTC)


def iso(moment: datetime | None) -> str | None:
    """One ISO 8601 shape for every time in every export: millisecond precision, UTC offset."""
    utc = as_utc(moment)
    return utc.isoformat(timespec="milliseconds") if utc else None
