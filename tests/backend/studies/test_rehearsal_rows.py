"""Rehearsal sessions borrow plan rows without holding them, walking the whole plan."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from tests.support.bots import StaffApi, WizardBot, staff_api, study_with_plan


@pytest.fixture
def pi(client: TestClient, engine: Engine) -> StaffApi:
    return staff_api(client, engine, "pi")


def _row_of(pi: StaffApi, study_id: int, wizard: WizardBot) -> int:
    """The plan row number the session's interactions came from."""
    planned = [i["condition"] for i in wizard.snapshot["interactions"]]
    faces = [i["face"] for i in wizard.snapshot["interactions"]]
    for row in pi.get(f"/api/studies/{study_id}/plan"):
        interactions = sorted(row["interactions"], key=lambda i: i["position"])
        if [i["condition"] for i in interactions] == planned and [
            i["face"] for i in interactions
        ] == faces:
            return int(row["row_number"])
    raise AssertionError("the session matches no plan row")


def test_consecutive_rehearsals_walk_every_row_then_start_again(pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=4, seed=3)
    rows = [_row_of(pi, study_id, WizardBot.create(pi, study_id, rehearsal=True)) for _ in range(6)]
    assert rows == [1, 2, 3, 4, 1, 2]
    participants = pi.get(f"/api/studies/{study_id}/participants")
    assert {p["code"] for p in participants} == {f"R00{n}" for n in range(1, 7)}
    assert all(p["row_number"] is None for p in participants), "a rehearsal held a row"


def test_a_rehearsal_practises_the_next_participants_row_first(pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=4, seed=3)
    real = WizardBot.create(pi, study_id)  # P001 holds row 1
    assert _row_of(pi, study_id, real) == 1
    rows = [_row_of(pi, study_id, WizardBot.create(pi, study_id, rehearsal=True)) for _ in range(5)]
    assert rows == [2, 1, 3, 4, 2]  # every row once before any row twice
    assert _row_of(pi, study_id, WizardBot.create(pi, study_id)) == 2  # still free for P002
