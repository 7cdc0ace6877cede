"""Ids of withdrawn data are never handed out again (SQLite AUTOINCREMENT, PostgreSQL
identity): a console tab, a file name or an event cursor naming a deleted id must never
come to mean another participant."""

from __future__ import annotations

import random
from pathlib import Path

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

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
from chameleons.backend.withdrawal.service import withdraw_participant
from tests.support.factories import add_completed_participant, populate

MODELS = (Participant, Session, Interaction, Suggestion, QuestionnaireResponse, Recording, Event)


def all_ids(db: DbSession) -> dict[str, set[int]]:
    return {model.__tablename__: set(db.scalars(select(model.id))) for model in MODELS}


def test_the_next_participant_gets_new_ids_after_the_last_one_withdrew(
    db_session: DbSession, tmp_path: Path
) -> None:
    data_dir = tmp_path / "data"
    data = populate(db_session, 2, free_rows=1, recordings_dir=data_dir / "recordings")
    db_session.commit()
    before = {table: max(ids) for table, ids in all_ids(db_session).items()}
    assert data.session_ids[-1] == before["session"], "P002 holds the highest ids"
    withdraw_participant(db_session, data.study_id, "P002", "P002", data_dir)
    db_session.commit()
    remaining = all_ids(db_session)
    assert max(remaining["session"]) < before["session"]

    study = db_session.get(Study, data.study_id)
    assert study is not None
    row = db_session.scalars(
        select(PlanRow).where(PlanRow.study_id == study.id, PlanRow.row_number == 3)
    ).one()
    add_completed_participant(
        db_session, study, data.spec, row, code="P003", rng=random.Random(3),
        recordings_dir=data_dir / "recordings",
    )  # fmt: skip
    db_session.commit()
    for table, ids in all_ids(db_session).items():
        new = ids - remaining[table]
        assert new, f"P003 added no {table} row"
        assert min(new) > before[table], f"{table} handed out a withdrawn id again"
