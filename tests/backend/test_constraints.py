"""The database itself refuses illegal data (on SQLite and PostgreSQL)."""

from __future__ import annotations

from typing import Any

import pytest
from sqlalchemy import func, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from chameleons.backend.models import (
    Interaction,
    Participant,
    PlanRow,
    Study,
    Suggestion,
)
from chameleons.backend.models import Session as StudySession


def _study_with_session(db: Session) -> tuple[Study, StudySession]:
    study = Study(name="s", config={}, config_hash="h" * 64)
    db.add(study)
    db.flush()
    row = PlanRow(study_id=study.id, row_number=1, interactions=[])
    db.add(row)
    db.flush()
    participant = Participant(study_id=study.id, code="P001", plan_row_id=row.id)
    db.add(participant)
    db.flush()
    session = StudySession(
        study_id=study.id, participant_id=participant.id, plan_row_id=row.id,
        phone_token="t" * 40, short_code="ABC123",
    )  # fmt: skip
    db.add(session)
    db.flush()
    return study, session


def _interaction(session_id: int, position: int) -> Interaction:
    fields: dict[str, Any] = {
        "planned_condition": "copy", "condition": "copy", "actor": "m1", "robot_name": "Nova",
        "face": "face-1", "task": "lunar", "item_set": "better", "presented_order": ["a"],
    }  # fmt: skip
    return Interaction(session_id=session_id, position=position, **fields)


def test_participant_code_unique_per_study(db_session: Session) -> None:
    study, _ = _study_with_session(db_session)
    db_session.add(Participant(study_id=study.id, code="P001"))
    with pytest.raises(IntegrityError):
        db_session.flush()


def test_one_interaction_per_position(db_session: Session) -> None:
    _, session = _study_with_session(db_session)
    db_session.add(_interaction(session.id, 1))
    db_session.flush()
    db_session.add(_interaction(session.id, 1))
    with pytest.raises(IntegrityError):
        db_session.flush()


@pytest.mark.parametrize(
    ("index", "kind", "from_rank", "to_rank"),
    [(0, "optimal", 3, 1), (1, "clever", 3, 1), (1, "optimal", 2, 2), (1, "optimal", 2, 0)],
)
def test_suggestion_checks(
    db_session: Session, index: int, kind: str, from_rank: int, to_rank: int
) -> None:
    _, session = _study_with_session(db_session)
    interaction = _interaction(session.id, 1)
    db_session.add(interaction)
    db_session.flush()
    db_session.add(
        Suggestion(interaction_id=interaction.id, index=index, item="water",
                   from_rank=from_rank, to_rank=to_rank, kind=kind)
    )  # fmt: skip
    with pytest.raises(IntegrityError):
        db_session.flush()


def test_a_suggestion_may_move_down_and_a_study_may_make_more_than_three(
    db_session: Session,
) -> None:
    _, session = _study_with_session(db_session)
    interaction = _interaction(session.id, 1)
    db_session.add(interaction)
    db_session.flush()
    db_session.add_all(
        Suggestion(interaction_id=interaction.id, index=index, item="water",
                   from_rank=2, to_rank=4, kind="optimal")
        for index in (1, 5)
    )  # fmt: skip
    db_session.flush()
    assert db_session.scalar(select(func.count()).select_from(Suggestion)) == 2


def test_deleting_a_participant_removes_their_session_rows(db_session: Session) -> None:
    _, session = _study_with_session(db_session)
    interaction = _interaction(session.id, 1)
    db_session.add(interaction)
    db_session.flush()
    participant = db_session.get(Participant, session.participant_id)
    db_session.delete(participant)
    db_session.flush()
    db_session.expunge_all()
    for model in (StudySession, Interaction):
        assert db_session.scalar(select(func.count()).select_from(model)) == 0
