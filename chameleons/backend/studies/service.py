"""Create studies, generate or extend their plan, register participants on plan rows.

Flushes only; the request's unit of work commits. Every change is an event.
"""

from __future__ import annotations

import re
import secrets

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from chameleons.backend.db import write_transaction
from chameleons.backend.events import repository as events
from chameleons.backend.models import Participant, PlanRow
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.models import Study as StudyRow
from chameleons.backend.studies.errors import ConflictError, InvalidInputError, NotFoundError
from chameleons.backend.studies.planner import planned_rows
from chameleons.backend.studies.specs import spec_of
from chameleons.experiment.design import PlanError
from chameleons.experiment.model import Study

MAX_PLAN_ROWS = 1000
CODE_PATTERN = re.compile(r"^[PR](\d+)$")


def create_study(db: Session, spec: Study, plan_seed: int | None = None) -> StudyRow:
    existing = db.scalars(
        select(StudyRow).where(
            StudyRow.name == spec.name, StudyRow.config_hash == spec.content_hash
        )
    ).first()
    if existing is not None:
        raise ConflictError(
            f"The study {spec.name!r} with this exact configuration already exists "
            f"(study {existing.id}). Change the configuration to create a new one."
        )
    seed = plan_seed if plan_seed is not None else secrets.randbelow(2**31)
    study = StudyRow(
        name=spec.name, config=spec.config, config_hash=spec.content_hash, plan_seed=seed
    )
    db.add(study)
    db.flush()
    events.record(
        db,
        "study.created",
        source="pi",
        study_id=study.id,
        payload={"name": spec.name, "config_hash": spec.content_hash, "plan_seed": seed},
    )
    return study


def list_studies(db: Session) -> list[StudyRow]:
    return list(db.scalars(select(StudyRow).order_by(StudyRow.id)))


def get_study(db: Session, study_id: int) -> StudyRow:
    study = db.get(StudyRow, study_id)
    if study is None:
        raise NotFoundError(f"There is no study {study_id}.")
    return study


def plan_rows(db: Session, study_id: int) -> list[PlanRow]:
    query = select(PlanRow).where(PlanRow.study_id == study_id).order_by(PlanRow.row_number)
    return list(db.scalars(query))


def generate_plan(
    db: Session, study: StudyRow, participants: int, seed: int | None = None
) -> list[PlanRow]:
    """Generate the plan, or extend it to ``participants`` rows keeping existing rows."""
    if not 1 <= participants <= MAX_PLAN_ROWS:
        raise InvalidInputError(f"The number of participants must be 1 to {MAX_PLAN_ROWS}.")
    existing = plan_rows(db, study.id)
    if existing and seed is not None and seed != study.plan_seed:
        raise ConflictError(
            "The plan already has rows generated with another seed; it can only be extended."
        )
    if participants <= len(existing):
        raise ConflictError(
            f"The plan already has {len(existing)} rows; to extend it ask for more than "
            f"{len(existing)} participants."
        )
    if seed is not None:
        study.plan_seed = seed
    try:
        rows = planned_rows(spec_of(study), participants, study.plan_seed)
    except PlanError as exc:
        raise InvalidInputError(f"The study cannot be planned: {exc}") from exc
    for old, new in zip(existing, rows, strict=False):
        if old.interactions != new:
            raise ConflictError(
                f"The planner would change row {old.row_number}, which is already in the plan; "
                "the plan was left unchanged."
            )
    added = [
        PlanRow(study_id=study.id, row_number=number, interactions=interactions)
        for number, interactions in enumerate(rows, start=1)
        if number > len(existing)
    ]
    db.add_all(added)
    db.flush()
    events.record(
        db,
        "plan.extended" if existing else "plan.generated",
        source="pi",
        study_id=study.id,
        payload={"rows_before": len(existing), "rows": participants, "seed": study.plan_seed},
    )
    return plan_rows(db, study.id)


def next_free_row(db: Session, study: StudyRow) -> PlanRow | None:
    """The row the next participant gets: a row freed by a withdrawal or handed on from a
    dropout first (so a replacement keeps the balance), otherwise the lowest unused row."""
    taken = select(Participant.plan_row_id).where(Participant.plan_row_id.is_not(None))
    freed = (PlanRow.withdrawals + PlanRow.dropouts) > 0
    query = (
        select(PlanRow)
        .where(PlanRow.study_id == study.id, PlanRow.id.not_in(taken))
        .order_by(freed.desc(), PlanRow.row_number)
        .limit(1)  # one row, not every free row's plan read and dropped (issue 34)
    )
    return db.scalars(query).first()


def rehearsal_row(db: Session, study: StudyRow) -> PlanRow | None:
    """The row a rehearsal session borrows (it never holds one): the row the fewest
    rehearsal sessions have used, the next participant's row first among equals, then row
    order. Consecutive rehearsals so walk the whole plan, and a number of rehearsals that
    is a multiple of the plan's balance period is as balanced as the plan itself."""
    rows = plan_rows(db, study.id)
    if not rows:
        return None
    counts = (
        select(SessionRow.plan_row_id, func.count())
        .where(SessionRow.study_id == study.id, SessionRow.is_rehearsal.is_(True))
        .group_by(SessionRow.plan_row_id)
    )
    used = dict(db.execute(counts).tuples().all())
    upcoming = next_free_row(db, study)
    return min(rows, key=lambda row: (used.get(row.id, 0), row is not upcoming, row.row_number))


def register_participant(db: Session, study: StudyRow, rehearsal: bool = False) -> Participant:
    """A new pseudonymous participant (``P001``...; rehearsals ``R001``... and no plan row)."""
    lock_registrations(db, study)
    row = next_free_row(db, study)
    if row is None and not rehearsal:
        count = len(plan_rows(db, study.id))
        raise ConflictError(
            f"All {count} plan rows are taken. Extend the plan before registering another "
            "participant."
        )
    participant = Participant(
        study_id=study.id,
        code=_next_code(db, study, "R" if rehearsal else "P"),
        plan_row_id=None if rehearsal else row.id if row else None,
        is_rehearsal=rehearsal,
    )
    db.add(participant)
    db.flush()
    events.record(
        db,
        "participant.registered",
        source="staff",
        study_id=study.id,
        payload={
            "code": participant.code,
            "row_number": row.row_number if row and not rehearsal else None,
            "replacement": bool(
                row and not rehearsal and (row.withdrawals > 0 or row.dropouts > 0)
            ),
            "rehearsal": rehearsal,
        },
    )
    return participant


def lock_registrations(db: Session, study: StudyRow) -> None:
    """Serialise registrations of one study before reading its free rows and codes: two at
    once took the same plan row (a 500 on ``participant.plan_row_id``'s UniqueConstraint,
    found by bench/server_hold.py). The study's row lock on PostgreSQL; SQLite's write lock
    (``write_transaction``; FOR UPDATE is a no-op there)."""
    write_transaction(db)
    db.execute(select(StudyRow.id).where(StudyRow.id == study.id).with_for_update())


def release_plan_row(db: Session, participant: Participant) -> PlanRow | None:
    """Free a withdrawn participant's plan row for the next replacement (the caller deletes
    the participant's data). The event names the row, not the participant."""
    if participant.plan_row_id is None:
        return None
    row = db.get(PlanRow, participant.plan_row_id)
    participant.plan_row_id = None
    db.flush()
    if row is None:
        return None
    row.withdrawals += 1
    events.record(
        db,
        "plan_row.released",
        source="pi",
        study_id=row.study_id,
        payload={"row_number": row.row_number, "withdrawals": row.withdrawals},
    )
    return row


def participant_by_code(db: Session, study: StudyRow, code: str) -> Participant:
    participant = db.scalars(
        select(Participant).where(Participant.study_id == study.id, Participant.code == code)
    ).first()
    if participant is None:
        raise NotFoundError(f"Study {study.id} has no participant {code!r}.")
    return participant


def _next_code(db: Session, study: StudyRow, prefix: str) -> str:
    """Codes are never reused, even after a withdrawal deleted the participant: numbering
    continues after every participant ever registered on a plan row."""
    codes = db.scalars(select(Participant.code).where(Participant.study_id == study.id)).all()
    numbers = [
        int(match.group(1))
        for code in codes
        if code.startswith(prefix) and (match := CODE_PATTERN.match(code))
    ]
    number = max(numbers, default=0) + 1
    if prefix == "P":
        withdrawn = db.scalar(
            select(func.coalesce(func.sum(PlanRow.withdrawals), 0)).where(
                PlanRow.study_id == study.id
            )
        )
        registered = sum(1 for code in codes if code.startswith("P"))
        number = max(number, registered + int(withdrawn or 0) + 1)
    taken = set(codes)
    while f"{prefix}{number:03d}" in taken:
        number += 1
    return f"{prefix}{number:03d}"
