"""Withdrawal leaves no trace of the participant, in any table or file, on both databases."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, func, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import (
    Base,
    Event,
    Interaction,
    Participant,
    PlanRow,
    Session,
)
from chameleons.backend.withdrawal.service import (
    WITHDRAWN_EVENT,
    ParticipantNotFoundError,
    WithdrawalError,
    withdraw_participant,
)
from tests.backend.test_auth import add_user, csrf_from, login
from tests.support.factories import PopulatedStudy, populate


def all_rows(db: DbSession) -> dict[str, list[dict[str, Any]]]:
    """Every row of every table, as the database holds it."""
    return {
        table.name: [dict(row._mapping) for row in db.execute(select(table))]
        for table in Base.metadata.sorted_tables
    }


def text_of(rows: dict[str, list[dict[str, Any]]]) -> str:
    return json.dumps(rows, default=str)


def ids_of(db: DbSession, code: str) -> dict[str, set[int]]:
    participant = db.scalars(select(Participant).where(Participant.code == code)).one()
    sessions = set(db.scalars(select(Session.id).where(Session.participant_id == participant.id)))
    interactions = set(
        db.scalars(select(Interaction.id).where(Interaction.session_id.in_(sessions)))
    )
    return {
        "participant_id": {participant.id},
        "session_id": sessions,
        "interaction_id": interactions,
    }


def assert_no_trace(db: DbSession, code: str, ids: dict[str, set[int]]) -> None:
    rows = all_rows(db)
    assert code not in text_of(rows)
    references = {"participant": "id", "session": "id", "interaction": "id"}
    for table, table_rows in rows.items():
        for row in table_rows:
            for column, withdrawn in ids.items():
                assert row.get(column) not in withdrawn, f"{table}.{column} still points at it"
            key = references.get(table)
            if key:
                owner = {"participant": "participant_id", "session": "session_id"}.get(
                    table, "interaction_id"
                )
                assert row[key] not in ids[owner], f"{table} row {row[key]} survived"


@pytest.fixture
def populated(db_session: DbSession, tmp_path: Path) -> PopulatedStudy:
    data = populate(db_session, 4, recordings_dir=tmp_path / "data" / "recordings")
    # What the session flow logs at registration: a study-level event naming the code.
    db_session.add(
        Event(
            study_id=data.study_id,
            kind="participant.registered",
            source="staff",
            payload={"code": "P002", "row_number": 2},
        )
    )
    db_session.commit()
    return data


def test_withdrawal_deletes_every_row_and_file(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    ids = ids_of(db_session, "P002")
    before = {name: len(rows) for name, rows in all_rows(db_session).items()}
    own_files = [
        p for p in populated.recording_paths if f"session-{populated.session_ids[1]}" in str(p)
    ]
    other_files = [p for p in populated.recording_paths if p not in own_files]
    assert len(own_files) == 6
    result = withdraw_participant(db_session, populated.study_id, "P002", "P002", tmp_path / "data")
    db_session.commit()
    assert result.files_deleted == 6
    assert result.plan_row_number == 2
    assert_no_trace(db_session, "P002", ids)
    assert not any(path.exists() for path in own_files)
    assert not own_files[0].parent.exists(), "the emptied recording directory remains"
    assert all(path.exists() for path in other_files)
    after = {name: len(rows) for name, rows in all_rows(db_session).items()}
    assert after["participant"] == before["participant"] - 1
    assert after["interaction"] == before["interaction"] - 3
    row = db_session.scalars(select(PlanRow).where(PlanRow.row_number == 2)).one()
    assert row.withdrawals == 1
    holder = select(func.count()).where(Participant.plan_row_id == row.id)
    assert db_session.scalar(holder) == 0


def test_the_audit_event_has_no_content(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    withdraw_participant(db_session, populated.study_id, "P003", " P003 ", tmp_path)
    db_session.commit()
    audit = db_session.scalars(select(Event).where(Event.kind == WITHDRAWN_EVENT)).one()
    assert audit.payload == {"plan_row": 3}
    assert audit.session_id is None
    assert audit.interaction_id is None
    assert audit.client_id is None


def test_a_wrong_confirmation_deletes_nothing(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    before = text_of(all_rows(db_session))
    with pytest.raises(WithdrawalError, match="type the participant code P002"):
        withdraw_participant(db_session, populated.study_id, "P002", "P001", tmp_path / "data")
    with pytest.raises(ParticipantNotFoundError):
        withdraw_participant(db_session, populated.study_id, "P099", "P099", tmp_path / "data")
    db_session.commit()
    assert text_of(all_rows(db_session)) == before
    assert all(path.exists() for path in populated.recording_paths)


def test_pi_withdraws_through_the_confirmation_form(
    client: TestClient, engine: Engine, settings: Any
) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, 2, recordings_dir=settings.data_dir / "recordings")
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    page = client.get("/pi/participants/P001/withdraw")
    assert page.status_code == 200
    assert "6 files" in page.text
    token = csrf_from(page.text)
    url = "/pi/participants/P001/withdraw"
    assert client.post(url, data={"confirm": "P001"}).status_code == 403  # no CSRF token
    wrong = client.post(url, data={"confirm": "p001", "csrf_token": token})
    assert wrong.status_code == 400
    assert "type the participant code P001 exactly" in wrong.text
    done = client.post(url, data={"confirm": "P001", "csrf_token": token}, follow_redirects=False)
    assert done.status_code == 200
    assert "P001 was withdrawn" in done.text
    assert "6 face recording files of P001" in done.text
    assert "Not removed from here" in done.text
    assert "Backups and copies of the database" in done.text
    assert f'href="/pi?study={data.study_id}"' in done.text
    with session_scope(build_sessionmaker(engine)) as db:
        assert "P001" not in text_of(all_rows(db))
    assert not any(p.exists() for p in data.recording_paths[:6])
    assert client.get(url).status_code == 404


def test_withdraw_api_needs_pi_and_csrf(client: TestClient, engine: Engine) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        populate(db, 1)
    add_user(engine, "wiz", "right password", "wizard")
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "wiz", "right password")
    token = csrf_from(client.get("/").text)
    url = "/api/pi/participants/P001/withdraw"
    headers = {"X-CSRF-Token": token}
    assert client.post(url, json={"confirm": "P001"}, headers=headers).status_code == 403
    login(client, "pia", "correct horse")
    token = csrf_from(client.get("/").text)
    assert client.post(url, json={"confirm": "P001"}).status_code == 403
    response = client.post(url, json={"confirm": "P001"}, headers={"X-CSRF-Token": token})
    assert response.status_code == 200
    body = response.json()
    assert (body["plan_row"], body["sessions"], body["files_deleted"]) == (1, 1, 0)
    assert body["removed"][0].startswith("P001's 1 session with 3 interactions")
    assert any("Backups" in sentence for sentence in body["not_removed"])
    again = client.post(url, json={"confirm": "P001"}, headers={"X-CSRF-Token": token})
    assert again.status_code == 404


def test_journals_and_unindexed_worker_files_go_too(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    data_dir = tmp_path / "data"
    ids = ids_of(db_session, "P001")["interaction_id"]
    indexed = [
        p for p in populated.recording_paths if f"session-{populated.session_ids[0]}" in str(p)
    ]
    journal = indexed[0].with_name(indexed[0].name + ".journal")
    journal.write_bytes(b"crash leftover")
    first = min(ids)
    unindexed = data_dir / "recordings" / "booth-1" / f"interaction-{first}-part2-agent.parquet"
    unindexed.parent.mkdir(parents=True)
    unindexed.write_bytes(b"never indexed")
    unrelated = unindexed.with_name(f"interaction-{first}0-part2-agent.parquet")
    unrelated.write_bytes(b"someone else")
    result = withdraw_participant(db_session, populated.study_id, "P001", "P001", data_dir)
    assert result.files_deleted == len(indexed) + 2
    assert not journal.exists()
    assert not unindexed.exists()
    assert unrelated.exists()
