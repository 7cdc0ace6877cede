"""Rehearsal marking: out of exports and analysis unless asked, plan row freed and reclaimed."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.export.scoring import score_rows
from chameleons.backend.models import Participant, Session, Study
from chameleons.backend.withdrawal.rehearsal import RehearsalError, set_rehearsal
from tests.backend.test_auth import add_user, csrf_from, login
from tests.support.factories import populate


def codes_in_scores(db: DbSession, include_rehearsal: bool = False) -> set[str]:
    study = db.scalars(select(Study)).one()
    from chameleons.experiment.study import study_from_config

    rows = score_rows(db, study, study_from_config(study.config), include_rehearsal)
    return {row["participant"] for row in rows}


def test_marking_and_unmarking_a_rehearsal(db_session: DbSession) -> None:
    data = populate(db_session, 3)
    participant = set_rehearsal(db_session, data.study_id, "P002", True)
    assert participant.is_rehearsal
    assert participant.plan_row_id is None
    sessions = db_session.scalars(select(Session).where(Session.participant_id == participant.id))
    assert all(session.is_rehearsal for session in sessions)
    assert codes_in_scores(db_session) == {"P001", "P003"}
    assert codes_in_scores(db_session, include_rehearsal=True) == {"P001", "P002", "P003"}
    set_rehearsal(db_session, data.study_id, "P002", False)
    assert participant.plan_row_id is not None
    assert codes_in_scores(db_session) == {"P001", "P002", "P003"}


def test_unmarking_refuses_when_the_row_was_given_away(db_session: DbSession) -> None:
    data = populate(db_session, 2)
    freed = set_rehearsal(db_session, data.study_id, "P001", True)
    session = db_session.scalars(select(Session).where(Session.participant_id == freed.id)).one()
    replacement = Participant(study_id=data.study_id, code="P003", plan_row_id=session.plan_row_id)
    db_session.add(replacement)
    db_session.flush()
    with pytest.raises(RehearsalError, match="now belongs to P003"):
        set_rehearsal(db_session, data.study_id, "P001", False)


def test_rehearsal_form_needs_pi_and_csrf(
    client: TestClient, engine: Engine, tmp_path: Path
) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, 2)
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    token = csrf_from(client.get("/").text)
    url = f"/pi/participants/P002/rehearsal?study={data.study_id}"
    assert client.post(url, data={"rehearsal": "true"}).status_code == 403
    done = client.post(url, data={"rehearsal": "true", "csrf_token": token}, follow_redirects=False)
    assert done.status_code == 303
    with session_scope(build_sessionmaker(engine)) as db:
        assert codes_in_scores(db) == {"P001"}
    api = client.post(
        "/api/pi/participants/P002/rehearsal",
        json={"rehearsal": False},
        headers={"X-CSRF-Token": token},
    )
    assert api.json() == {"participant": "P002", "rehearsal": False}
