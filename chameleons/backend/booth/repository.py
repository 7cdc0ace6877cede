"""Reads and writes of the booth flow: which session runs on a booth, an interaction with its
session, the recording index, the yoked-control candidates and the chosen natural source."""

from __future__ import annotations

from collections.abc import Collection, Iterator
from dataclasses import dataclass

from sqlalchemy import select
from sqlalchemy.orm import Session

from chameleons.backend.models import Event, Interaction, Participant, Recording, Study
from chameleons.backend.models import Session as SessionRow

RUNNING_STEPS = frozenset({"discussion", "ranking", "negotiation", "questionnaire"})
NATURAL_SOURCE = "behaviour.natural_source"
RECORDING_STARTED = "recording.started"
YokedCandidate = tuple[Recording, str, int, str]  # recording, participant code, position, condition


@dataclass(frozen=True)
class Located:
    """An interaction with the session it belongs to."""

    session: SessionRow
    interaction: Interaction

    @property
    def running(self) -> bool:
        return self.session.state == "running" and self.interaction.state in RUNNING_STEPS

    def study(self, db: Session) -> Study:
        study = db.get(Study, self.session.study_id)
        if study is None:
            raise LookupError(f"session {self.session.id} has lost its study")
        return study


def locate(db: Session, interaction_id: int) -> Located | None:
    interaction = db.get(Interaction, interaction_id)
    if interaction is None:
        return None
    session = db.get(SessionRow, interaction.session_id)
    return Located(session, interaction) if session is not None else None


def active_session(db: Session, booth: str) -> SessionRow | None:
    """The session running on ``booth`` (the most recently started, should there be more)."""
    query = (
        select(SessionRow)
        .where(SessionRow.booth == booth, SessionRow.state == "running")
        .order_by(SessionRow.started_at.desc(), SessionRow.id.desc())
        .limit(1)
    )
    return db.scalars(query).first()


def running_interaction(db: Session, session: SessionRow) -> Interaction | None:
    """The session's current interaction while it runs (between interactions: None)."""
    query = select(Interaction).where(
        Interaction.session_id == session.id, Interaction.position == session.current_position
    )
    interaction = db.scalars(query).first()
    if interaction is None or interaction.state not in RUNNING_STEPS:
        return None
    return interaction


def indexed_paths(db: Session, interaction_id: int) -> set[str]:
    query = select(Recording.path).where(Recording.interaction_id == interaction_id)
    return set(db.scalars(query))


def recordings_of(db: Session, interaction_id: int) -> list[Recording]:
    query = (
        select(Recording)
        .where(Recording.interaction_id == interaction_id)
        .order_by(Recording.stream, Recording.path)
    )
    return list(db.scalars(query))


def yoked_candidates(
    db: Session,
    interaction: Interaction,
    session: SessionRow,
    min_frames: int,
    conditions: Collection[str],
) -> Iterator[YokedCandidate]:
    """Participant streams of other participants' finished interactions of this study in
    ``conditions`` that ended before ``interaction`` started, the most recent first, with
    whose they are. Rehearsal recordings (staff faces) only yoke rehearsals."""
    query = (
        select(Recording, Participant.code, Interaction.position, Interaction.condition)
        .join(Interaction, Interaction.id == Recording.interaction_id)
        .join(SessionRow, SessionRow.id == Interaction.session_id)
        .join(Participant, Participant.id == SessionRow.participant_id)
        .where(
            Recording.stream == "participant",
            Recording.frames >= min_frames,
            Interaction.state == "done",
            Interaction.condition.in_(list(conditions)),
            SessionRow.study_id == session.study_id,
            SessionRow.participant_id != session.participant_id,
        )
        .order_by(Interaction.ended_at.desc(), Recording.id.desc())
    )
    if not session.is_rehearsal:
        query = query.where(SessionRow.is_rehearsal.is_(False))
    if interaction.started_at is not None:
        query = query.where(Interaction.ended_at <= interaction.started_at)
    yield from db.execute(query).tuples()


def chosen_natural_source(db: Session, interaction_id: int) -> Event | None:
    query = (
        select(Event)
        .where(Event.interaction_id == interaction_id, Event.kind == NATURAL_SOURCE)
        .order_by(Event.id.desc())
        .limit(1)
    )
    return db.scalars(query).first()


def recording_started(db: Session, interaction_id: int) -> bool:
    query = select(Event.id).where(
        Event.interaction_id == interaction_id, Event.kind == RECORDING_STARTED
    )
    return db.scalars(query.limit(1)).first() is not None
