"""Plan progress and the live balance of the counterbalancing.

Balance is computed by the experiment core's ``balance_report`` from what actually ran
(the counted sessions that have started, with each interaction's condition as run), and
beside it from the plan rows of those same sessions, so a deviation caused while running
(a condition switch) is told apart from one the plan itself has (an incomplete block).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.queries import session_filter
from chameleons.backend.models import Interaction, Participant, PlanRow, Session, Study
from chameleons.experiment.balance import BalanceReport, balance_report
from chameleons.experiment.model import Study as StudySpec


@dataclass(frozen=True)
class Progress:
    rows: int
    used: int
    free: int
    withdrawn: int
    replaced: int
    rehearsal_participants: int
    completed_sessions: int
    started_sessions: int


@dataclass(frozen=True)
class Slot:
    """One interaction as the balance report reads it (actual or planned)."""

    condition: str
    actor: str
    face: str
    task: str
    item_set: str
    item_order: Sequence[str]


@dataclass(frozen=True)
class SlotRow:
    interactions: Sequence[Slot]


@dataclass
class BalanceCell:
    name: str
    actual: int
    planned: int | None
    deviates: bool


@dataclass
class BalanceTable:
    id: str
    constraint: int
    description: str
    ideal: float
    max_deviation: float
    ok: bool
    differs_from_plan: bool
    status: str
    verdict: str
    cells: list[BalanceCell] = field(default_factory=list)


def plan_progress(db: DbSession, study: Study) -> Progress:
    rows = list(db.scalars(select(PlanRow).where(PlanRow.study_id == study.id)))
    holders = set(
        db.scalars(
            select(Participant.plan_row_id).where(
                Participant.study_id == study.id, Participant.plan_row_id.is_not(None)
            )
        )
    )
    rehearsals = db.scalars(
        select(Participant.id).where(
            Participant.study_id == study.id, Participant.is_rehearsal.is_(True)
        )
    ).all()
    states_query = (
        select(Session.state)
        .join(Participant, Participant.id == Session.participant_id)
        .where(*session_filter(study.id, False))
    )
    states = list(db.scalars(states_query))
    return Progress(
        rows=len(rows),
        used=sum(1 for row in rows if row.id in holders),
        free=sum(1 for row in rows if row.id not in holders),
        withdrawn=sum(row.withdrawals for row in rows),
        replaced=sum(1 for row in rows if row.withdrawals and row.id in holders),
        rehearsal_participants=len(rehearsals),
        completed_sessions=sum(1 for state in states if state == "complete"),
        started_sessions=sum(1 for state in states if state != "pending"),
    )


def _run_rows(
    db: DbSession, study: Study, include_rehearsal: bool
) -> tuple[list[SlotRow], list[SlotRow]]:
    """(actual, planned) rows of the counted sessions that have started."""
    query = (
        select(Session, PlanRow)
        .join(Participant, Participant.id == Session.participant_id)
        .join(PlanRow, PlanRow.id == Session.plan_row_id)
        .where(*session_filter(study.id, include_rehearsal), Session.started_at.is_not(None))
        .order_by(Session.id)
    )
    actual, planned = [], []
    for session, plan_row in db.execute(query).tuples():
        interactions = db.scalars(
            select(Interaction)
            .where(Interaction.session_id == session.id)
            .order_by(Interaction.position)
        )
        actual.append(SlotRow([_actual_slot(i) for i in interactions]))
        planned.append(SlotRow([_planned_slot(p) for p in plan_row.interactions]))
    return actual, planned


def _actual_slot(interaction: Interaction) -> Slot:
    order = interaction.presented_order or []
    return Slot(
        interaction.condition,
        interaction.actor,
        interaction.face,
        interaction.task,
        interaction.item_set,
        [str(item) for item in order],
    )


def _planned_slot(planned: dict[str, Any]) -> Slot:
    return Slot(
        str(planned.get("condition")),
        str(planned.get("actor")),
        str(planned.get("face")),
        str(planned.get("task")),
        str(planned.get("item_set")),
        [str(item) for item in planned.get("item_order", [])],
    )


def live_balance(
    db: DbSession, study: Study, spec: StudySpec, include_rehearsal: bool = False
) -> tuple[BalanceReport, list[BalanceTable]]:
    actual_rows, planned_rows = _run_rows(db, study, include_rehearsal)
    actual = balance_report(spec, actual_rows)
    planned = balance_report(spec, planned_rows)
    planned_by_id = {c.id: c for c in planned.constraints}
    tables = []
    for constraint in actual.constraints:
        plan = planned_by_id.get(constraint.id)
        cells = [
            BalanceCell(
                name,
                count,
                plan.counts.get(name, 0) if plan else None,
                abs(count - constraint.ideal) >= 1 - 1e-9,
            )
            for name, count in constraint.counts.items()
        ]
        tables.append(
            BalanceTable(
                constraint.id,
                constraint.constraint,
                constraint.description,
                constraint.ideal,
                constraint.max_deviation,
                constraint.ok,
                any(cell.planned != cell.actual for cell in cells),
                constraint.status,
                constraint.verdict(),
                cells,
            )
        )
    return actual, tables
