"""Staff JSON API: studies (PI creates them and their plan), participants (any staff)."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from fastapi import Depends, HTTPException, Request, status
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentPI, CurrentStaff
from chameleons.backend.booth.behaviour import demo_clip_warning
from chameleons.backend.dependencies import DbSession
from chameleons.backend.events.unit_of_work import WriteDb
from chameleons.backend.models import Participant, PlanRow
from chameleons.backend.models import Study as StudyRow
from chameleons.backend.routing import make_router
from chameleons.backend.studies import service
from chameleons.backend.studies.errors import http_errors
from chameleons.backend.studies.schemas import (
    ParticipantCreate,
    ParticipantRead,
    PlanRequest,
    PlanRowRead,
    StudyCreate,
    StudyRead,
)
from chameleons.backend.studies.specs import spec_of
from chameleons.backend.wizard import readiness
from chameleons.experiment.model import Study
from chameleons.experiment.study import StudyError, load_default_study, load_study

router = make_router(prefix="/api/studies", tags=["studies"])
WRITE = [Depends(verify_csrf)]


def study_read(db: Session, study: StudyRow, state: Any | None = None) -> StudyRead:
    """The study as staff see it; with the app's ``state``, also the languages whose prompt
    catalogues cannot run a session (``wizard.readiness``)."""
    rows = db.scalar(select(func.count()).where(PlanRow.study_id == study.id)) or 0
    people = db.scalar(select(func.count()).where(Participant.study_id == study.id)) or 0
    spec = spec_of(study)
    return StudyRead(
        id=study.id,
        name=study.name,
        config_hash=study.config_hash,
        plan_seed=study.plan_seed,
        is_active=study.is_active,
        created_at=study.created_at,
        plan_rows=rows,
        participants=people,
        warnings=list(spec.warnings),
        languages=list(spec.languages),
        default_language=spec.default_language,
        prompt_gaps={} if state is None else readiness.study_warnings(state, spec),
        natural_clip_warning="" if state is None else demo_clip_warning(state, spec),
    )


def participant_read(db: Session, participant: Participant) -> ParticipantRead:
    row = db.get(PlanRow, participant.plan_row_id) if participant.plan_row_id else None
    return ParticipantRead(
        id=participant.id,
        code=participant.code,
        status=participant.status,
        is_rehearsal=participant.is_rehearsal,
        row_number=row.row_number if row else None,
    )


def spec_from_yaml(text: str | None) -> Study:
    """The default study, or one from uploaded YAML (every problem reported, 422)."""
    if text is None:
        return load_default_study()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "study.yaml"
        path.write_text(text, encoding="utf-8")
        try:
            return load_study(path)
        except StudyError as exc:
            detail = {"message": "The study file has problems.", "problems": exc.problems}
            raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, detail) from exc


@router.get("")
def list_studies(request: Request, _user: CurrentStaff, db: DbSession) -> list[StudyRead]:
    state = request.app.state
    return [study_read(db, study, state) for study in service.list_studies(db)]


@router.post("", status_code=status.HTTP_201_CREATED, dependencies=WRITE)
def create_study(data: StudyCreate, request: Request, _pi: CurrentPI, db: WriteDb) -> StudyRead:
    spec = spec_from_yaml(data.yaml)
    with http_errors():
        study = service.create_study(db, spec, data.plan_seed)
        return study_read(db, study, request.app.state)


@router.get("/{study_id}")
def get_study(study_id: int, request: Request, _user: CurrentStaff, db: DbSession) -> StudyRead:
    with http_errors():
        return study_read(db, service.get_study(db, study_id), request.app.state)


@router.get("/{study_id}/plan")
def get_plan(study_id: int, _user: CurrentStaff, db: DbSession) -> list[PlanRowRead]:
    with http_errors():
        study = service.get_study(db, study_id)
    held = select(Participant.plan_row_id, Participant.code).where(
        Participant.study_id == study.id, Participant.plan_row_id.is_not(None)
    )
    codes = dict(db.execute(held).tuples().all())
    return [
        PlanRowRead(
            id=row.id,
            row_number=row.row_number,
            withdrawals=row.withdrawals,
            participant_code=codes.get(row.id),
            interactions=row.interactions,
        )
        for row in service.plan_rows(db, study.id)
    ]


@router.post("/{study_id}/plan", dependencies=WRITE)
def generate_plan(
    study_id: int, data: PlanRequest, request: Request, _pi: CurrentPI, db: WriteDb
) -> StudyRead:
    with http_errors():
        study = service.get_study(db, study_id)
        service.generate_plan(db, study, data.participants, data.seed)
        return study_read(db, study, request.app.state)


@router.get("/{study_id}/participants")
def list_participants(study_id: int, _user: CurrentStaff, db: DbSession) -> list[ParticipantRead]:
    with http_errors():
        study = service.get_study(db, study_id)
    people = db.scalars(
        select(Participant).where(Participant.study_id == study.id).order_by(Participant.id)
    )
    return [participant_read(db, person) for person in people]


@router.post("/{study_id}/participants", status_code=status.HTTP_201_CREATED, dependencies=WRITE)
def register_participant(
    study_id: int, data: ParticipantCreate, _user: CurrentStaff, db: WriteDb
) -> ParticipantRead:
    with http_errors():
        study = service.get_study(db, study_id)
        return participant_read(db, service.register_participant(db, study, data.rehearsal))
