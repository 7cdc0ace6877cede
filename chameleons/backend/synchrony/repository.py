"""Reads and writes of the synchrony feature: an interaction with its study, its recordings
and the robot's speech times, the interactions whose faces can pair as pseudo-dyads, and
the stored results."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass

from sqlalchemy import delete, func, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import (
    Event,
    Interaction,
    InteractionSynchrony,
    Participant,
    Recording,
    Session,
    Study,
)

SPEECH_START, SPEECH_END = "prompt.speech_start", "prompt.speech_end"


@dataclass(frozen=True)
class Context:
    interaction: Interaction
    session: Session
    participant: Participant
    study: Study

    @property
    def rehearsal(self) -> bool:
        return bool(self.session.is_rehearsal or self.participant.is_rehearsal)


def context(db: DbSession, interaction_id: int) -> Context | None:
    query = (
        select(Interaction, Session, Participant, Study)
        .join(Session, Session.id == Interaction.session_id)
        .join(Participant, Participant.id == Session.participant_id)
        .join(Study, Study.id == Session.study_id)
        .where(Interaction.id == interaction_id)
    )
    row = db.execute(query).first()
    return None if row is None else Context(*row)


def recordings(
    db: DbSession, interaction_ids: Iterable[int]
) -> dict[int, dict[str, list[Recording]]]:
    """Per interaction, its recordings by stream (parts in path order)."""
    found: dict[int, dict[str, list[Recording]]] = defaultdict(lambda: defaultdict(list))
    ids = list(interaction_ids)
    if ids:
        query = (
            select(Recording)
            .where(Recording.interaction_id.in_(ids))
            .order_by(Recording.interaction_id, Recording.stream, Recording.path)
        )
        for recording in db.scalars(query):
            found[recording.interaction_id][recording.stream].append(recording)
    return {i: dict(streams) for i, streams in found.items()}


def speech(db: DbSession, interaction_id: int) -> list[tuple[float, float]]:
    """The robot's speech as ``(start, end)`` on the worker's clock. A start without an end
    (the end was lost) lasts until the next start; a trailing one is open-ended (inf)."""
    query = (
        select(Event.kind, Event.worker_time)
        .where(Event.interaction_id == interaction_id, Event.kind.in_([SPEECH_START, SPEECH_END]),
               Event.worker_time.is_not(None))
        .order_by(Event.worker_time, Event.id)
    )  # fmt: skip
    intervals: list[tuple[float, float]] = []
    opened: float | None = None
    for kind, when in db.execute(query):
        if kind == SPEECH_START:
            if opened is not None:
                intervals.append((opened, float(when)))
            opened = float(when)
        elif opened is not None:
            intervals.append((opened, float(when)))
            opened = None
    if opened is not None:
        intervals.append((opened, float("inf")))
    return intervals


def partners(db: DbSession, found: Context) -> list[int]:
    """Interactions of the same study, of other participants, rehearsal or not as this one,
    with both streams recorded: the faces a pseudo-dyad may take (in id order)."""
    both = (
        select(Recording.interaction_id)
        .group_by(Recording.interaction_id)
        .having(func.count(func.distinct(Recording.stream)) >= 2)
    )
    query = (
        select(Interaction.id, Session.is_rehearsal, Participant.is_rehearsal)
        .join(Session, Session.id == Interaction.session_id)
        .join(Participant, Participant.id == Session.participant_id)
        .where(Session.study_id == found.study.id, Participant.id != found.participant.id,
               Interaction.id.in_(both))
        .order_by(Interaction.id)
    )  # fmt: skip
    return [i for i, session_r, participant_r in db.execute(query)
            if bool(session_r or participant_r) == found.rehearsal]  # fmt: skip


def stored(db: DbSession, interaction_ids: Iterable[int]) -> dict[int, InteractionSynchrony]:
    ids = list(interaction_ids)
    if not ids:
        return {}
    query = select(InteractionSynchrony).where(InteractionSynchrony.interaction_id.in_(ids))
    return {row.interaction_id: row for row in db.scalars(query)}


def replace(db: DbSession, row: InteractionSynchrony) -> InteractionSynchrony:
    """Store ``row`` as the interaction's synchrony (the previous one goes)."""
    db.execute(
        delete(InteractionSynchrony).where(
            InteractionSynchrony.interaction_id == row.interaction_id
        )
    )
    db.add(row)
    db.flush()
    return row


def interactions_of(
    db: DbSession, study_id: int | None = None, session_id: int | None = None,
    interaction_id: int | None = None,
) -> list[int]:  # fmt: skip
    """Interactions with a recording: of a study, a session, or one."""
    query = (
        select(Interaction.id)
        .join(Session, Session.id == Interaction.session_id)
        .where(Interaction.id.in_(select(Recording.interaction_id)))
        .order_by(Interaction.id)
    )
    if study_id is not None:
        query = query.where(Session.study_id == study_id)
    if session_id is not None:
        query = query.where(Session.id == session_id)
    if interaction_id is not None:
        query = query.where(Interaction.id == interaction_id)
    return list(db.scalars(query))


def forget_derived(db: DbSession, study_id: int, recording_ids: Iterable[int],
                   interaction_ids: Iterable[int]) -> list[int]:  # fmt: skip
    """Delete the synchrony of the study's interactions that was derived from these
    recordings (measured from them, or with them in its pseudo-pairs) or belongs to these
    interactions (a withdrawal: their robot replayed the withdrawn face); returns the
    interactions that lost theirs (``chameleons synchrony`` computes them again)."""
    gone, own = set(recording_ids), set(interaction_ids)
    query = (
        select(InteractionSynchrony)
        .join(Interaction, Interaction.id == InteractionSynchrony.interaction_id)
        .join(Session, Session.id == Interaction.session_id)
        .where(Session.study_id == study_id)
    )
    doomed: list[InteractionSynchrony] = []
    for row in db.scalars(query):
        used = set(row.recordings) | {i for pair in row.surrogates for ids in pair for i in ids}
        if row.interaction_id in own or used & gone:
            doomed.append(row)
    if doomed:
        ids = [row.id for row in doomed]
        db.execute(delete(InteractionSynchrony).where(InteractionSynchrony.id.in_(ids)))
    return [row.interaction_id for row in doomed]
