"""The sessions list and one session's detail, as the PI dashboard shows them."""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.dashboard.answer_rows import AnsweredPage, answered_pages
from chameleons.backend.dashboard.flags import SessionFlags, session_flags
from chameleons.backend.export.scoring import error_score
from chameleons.backend.export.selection import as_utc
from chameleons.backend.models import (
    Event,
    Interaction,
    Participant,
    PlanRow,
    QuestionnaireResponse,
    Recording,
    Session,
    Study,
    Suggestion,
)
from chameleons.backend.sessions.answers import FINAL_POSITION
from chameleons.backend.sessions.consent import BEFORE_POSITION
from chameleons.backend.withdrawal.files import recording_file
from chameleons.experiment.model import Study as StudySpec


@dataclass
class SessionSummary:
    id: int
    code: str
    participant_status: str
    state: str
    booth: str
    plan_row: int | None
    rehearsal: bool
    started_at: datetime | None
    duration_s: float | None
    flags: SessionFlags
    excluded: str | None = None  # the reason, when the PI excluded the participant
    can_hand_on: bool = False  # the plan row may go to a replacement (data kept)

    def to_dict(self) -> dict[str, Any]:
        return {
            "session": self.id,
            "participant": self.code,
            "participant_status": self.participant_status,
            "state": self.state,
            "booth": self.booth,
            "plan_row": self.plan_row,
            "rehearsal": self.rehearsal,
            "started_at": self.started_at.isoformat() if self.started_at else None,
            "duration_s": self.duration_s,
            "flags": [flag.__dict__ for flag in self.flags.flags],
            "excluded": self.excluded,
            "can_hand_on": self.can_hand_on,
        }


def _duration(session: Session) -> float | None:
    start, end = as_utc(session.started_at), as_utc(session.completed_at)
    return (end - start).total_seconds() if start and end else None


def session_summaries(db: DbSession, study: Study, spec: StudySpec) -> list[SessionSummary]:
    """Every session of the study (rehearsals included and marked), newest first."""
    query = (
        select(Session, Participant, PlanRow.row_number)
        .join(Participant, Participant.id == Session.participant_id)
        .outerjoin(PlanRow, PlanRow.id == Session.plan_row_id)
        .where(Session.study_id == study.id)
        .order_by(Session.created_at.desc(), Session.id.desc())
    )
    found = list(db.execute(query).tuples())
    flags = session_flags(db, spec, [session for session, _, _ in found])
    return [
        SessionSummary(
            session.id,
            participant.code,
            participant.status,
            session.state,
            session.booth,
            row_number,
            session.is_rehearsal or participant.is_rehearsal,
            as_utc(session.started_at),
            _duration(session),
            flags[session.id],
            participant.exclusion_reason if participant.excluded_at is not None else None,
            _can_hand_on(session, participant),
        )
        for session, participant, row_number in found
    ]


def _can_hand_on(session: Session, participant: Participant) -> bool:
    """The dashboard offers the row to a replacement for a dropout whose row it still holds:
    never started, ended early, or complete but excluded (the service checks again)."""
    if participant.plan_row_id is None or participant.is_rehearsal:
        return False
    if session.state in ("pending", "ended"):
        return True
    return session.state == "complete" and participant.excluded_at is not None


@dataclass
class RankedItem:
    item: str
    name: str
    expert_rank: int | None


@dataclass
class InteractionDetail:
    interaction: Interaction
    deviates: bool
    expert_order: list[RankedItem]
    presented: list[RankedItem]
    initial: list[RankedItem]
    final: list[RankedItem]
    initial_error: int | None
    final_error: int | None
    suggestions: list[Suggestion]
    questionnaires: list[AnsweredPage]
    recordings: list[tuple[Recording, bool]]
    item_names: dict[str, str] = field(default_factory=dict)  # item id -> its name


@dataclass(frozen=True)
class FlagLine:
    kind: str
    text: str
    count: int


@dataclass
class SessionDetail:
    session: Session
    participant: Participant
    plan_row: int | None
    summary_flags: SessionFlags
    interactions: list[InteractionDetail] = field(default_factory=list)
    before: list[AnsweredPage] = field(default_factory=list)  # about the participant
    final: list[AnsweredPage] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)

    @property
    def flag_lines(self) -> list[FlagLine]:
        """The session's flags, the same one once with how often (nine prompts not sent in
        one interaction are one line), in the order first raised."""
        counts: dict[tuple[str, str], int] = {}
        for flag in self.summary_flags.flags:
            key = (flag.kind, flag.text)
            counts[key] = counts.get(key, 0) + 1
        return [FlagLine(kind, text, count) for (kind, text), count in counts.items()]


def _ranked(spec: StudySpec, task: str, items: list[Any] | None) -> list[RankedItem]:
    result = []
    for item_id in items or []:
        try:
            item = spec.task(task).item(str(item_id))
            result.append(RankedItem(item.id, item.name, item.expert_rank))
        except KeyError:
            result.append(RankedItem(str(item_id), str(item_id), None))
    return result


def session_detail(
    db: DbSession, spec: StudySpec, session_id: int, data_dir: Path
) -> SessionDetail | None:
    session = db.get(Session, session_id)
    if session is None:
        return None
    participant = db.get(Participant, session.participant_id)
    assert participant is not None  # a foreign key guarantees it
    row = db.get(PlanRow, session.plan_row_id)
    answers = list(
        db.scalars(
            select(QuestionnaireResponse)
            .where(QuestionnaireResponse.session_id == session.id)
            .order_by(QuestionnaireResponse.id)
        )
    )
    interactions = list(
        db.scalars(
            select(Interaction)
            .where(Interaction.session_id == session.id)
            .order_by(Interaction.position)
        )
    )
    robots = {i.position: i.robot_name for i in interactions}
    detail = SessionDetail(
        session,
        participant,
        row.row_number if row else None,
        session_flags(db, spec, [session])[session.id],
        before=answered_pages(spec, [a for a in answers if a.position == BEFORE_POSITION], robots),
        final=answered_pages(spec, [a for a in answers if a.position == FINAL_POSITION], robots),
        events=list(
            db.scalars(
                select(Event)
                .where(Event.session_id == session.id)
                .order_by(Event.server_time, Event.id)
            )
        ),
    )
    for interaction in interactions:
        own = [a for a in answers if a.interaction_id == interaction.id]
        detail.interactions.append(
            _interaction_detail(db, spec, interaction, own, data_dir, robots)
        )
    return detail


def _interaction_detail(
    db: DbSession,
    spec: StudySpec,
    interaction: Interaction,
    answers: list[QuestionnaireResponse],
    data_dir: Path,
    robots: dict[int, str],
) -> InteractionDetail:
    presented = [str(item) for item in interaction.presented_order or []]
    try:
        expert = spec.expert_order(interaction.task, presented)
    except KeyError:
        expert = presented
    recordings = db.scalars(
        select(Recording)
        .where(Recording.interaction_id == interaction.id)
        .order_by(Recording.stream)
    )
    return InteractionDetail(
        interaction=interaction,
        deviates=interaction.condition != interaction.planned_condition,
        expert_order=_ranked(spec, interaction.task, expert),
        presented=_ranked(spec, interaction.task, presented),
        initial=_ranked(spec, interaction.task, interaction.initial_ranking),
        final=_ranked(spec, interaction.task, interaction.final_ranking),
        initial_error=error_score(spec, interaction.task, interaction.initial_ranking),
        final_error=error_score(spec, interaction.task, interaction.final_ranking),
        suggestions=list(
            db.scalars(
                select(Suggestion)
                .where(Suggestion.interaction_id == interaction.id)
                .order_by(Suggestion.index)
            )
        ),
        questionnaires=answered_pages(spec, answers, robots),
        recordings=[(r, recording_file(data_dir, r.path).is_file()) for r in recordings],
        item_names=_item_names(spec, interaction.task, presented),
    )


def _item_names(spec: StudySpec, task: str, items: list[str]) -> dict[str, str]:
    return {ranked.item: ranked.name for ranked in _ranked(spec, task, items)}
