"""Excluding a participant without deleting anything, and handing a dropout's plan row to a
replacement (real HTTP API and session flow, both databases)."""

from __future__ import annotations

import csv
import io
import random
import zipfile

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from tests.support.bots import (
    ApiError,
    StaffApi,
    WizardBot,
    run_session,
    staff_api,
    study_with_plan,
)


@pytest.fixture
def pi(client: TestClient, engine: Engine) -> StaffApi:
    return staff_api(client, engine, "pi")


def table(client: TestClient, study_id: int, name: str) -> list[dict[str, str]]:
    bundle = zipfile.ZipFile(
        io.BytesIO(client.get("/api/pi/export.zip", params={"study": study_id}).content)
    )
    return list(csv.DictReader(io.StringIO(bundle.read(f"{name}.csv").decode())))


def test_an_excluded_participant_keeps_their_data_and_leaves_the_analysis(
    client: TestClient, pi: StaffApi
) -> None:
    study_id = study_with_plan(pi, participants=6)
    codes = [run_session(pi, client, study_id, random.Random(n)).participant_code for n in range(4)]
    gone = codes[1]
    path = f"/api/pi/participants/{gone}/exclusion?study={study_id}"
    with pytest.raises(ApiError) as empty:
        pi.post(path, {"excluded": True, "reason": "  "})
    assert empty.value.status == 422
    answer = pi.post(path, {"excluded": True, "reason": "knew the study's hypothesis"})
    assert answer == {
        "participant": gone,
        "excluded": True,
        "reason": "knew the study's hypothesis",
    }
    with pytest.raises(ApiError) as twice:
        pi.post(path, {"excluded": True, "reason": "again"})
    assert twice.value.status == 409

    participants = {r["participant"]: r for r in table(client, study_id, "participants")}
    assert participants[gone]["excluded"] == "true"
    assert participants[gone]["exclusion_reason"] == "knew the study's hypothesis"
    assert participants[gone]["excluded_at"]
    assert participants[codes[0]]["excluded"] == "false"
    scores = [r for r in table(client, study_id, "scores") if r["participant"] == gone]
    assert len(scores) == 3
    assert all(r["excluded"] == "true" and r["accepted"] for r in scores)

    analysis = pi.get(f"/api/pi/analysis?study={study_id}")["analysis"]
    assert analysis["left_out"] == [
        {"participant": gone, "reason": "excluded by the PI: knew the study's hypothesis"}
    ]
    assert analysis["measures"]["trust"]["friedman"]["n"] == 3
    assert "4 participants in the data; 1 left out of every test" in analysis["summary"]
    overview = pi.get(f"/api/pi/overview?study={study_id}")
    row = next(s for s in overview["sessions"] if s["participant"] == gone)
    assert row["excluded"] == "knew the study's hypothesis"
    assert "excluded" in {flag["kind"] for flag in row["flags"]}
    assert overview["progress"]["excluded"] == 1
    assert overview["balance"]["participants"] == 3
    events = pi.get(f"/api/sessions/{row['session']}/events")
    assert any(e["kind"] == "participant.excluded" for e in events)

    assert pi.post(path, {"excluded": False})["excluded"] is False
    again = pi.get(f"/api/pi/analysis?study={study_id}")["analysis"]
    assert again["left_out"] == []
    assert again["measures"]["trust"]["friedman"]["n"] == 4


def test_a_dropout_s_row_goes_to_a_replacement_and_their_data_stay(
    client: TestClient, pi: StaffApi
) -> None:
    study_id = study_with_plan(pi, participants=4)
    first = run_session(pi, client, study_id, random.Random(1))
    dropout = WizardBot.create(pi, study_id)
    dropout.start()
    dropout.advance(1, "discussion")
    code = dropout.snapshot["participant"]["code"]
    row_path = f"/api/pi/participants/{code}/hand-on-row?study={study_id}"
    with pytest.raises(ApiError) as running:
        pi.post(row_path)
    assert running.value.status == 409
    assert "still running: end it first" in str(running.value.detail)
    pi.post(f"/api/sessions/{dropout.session_id}/end", {"reason": "participant_withdrew"})
    with pytest.raises(ApiError) as complete:
        pi.post(f"/api/pi/participants/{first.participant_code}/hand-on-row?study={study_id}")
    assert complete.value.status == 409
    assert "completed the study; exclude them first" in str(complete.value.detail)

    row_number = next(
        s["plan_row"]
        for s in pi.get(f"/api/pi/overview?study={study_id}")["sessions"]
        if s["participant"] == code
    )
    assert pi.post(row_path) == {"participant": code, "row_number": row_number}
    with pytest.raises(ApiError) as twice:
        pi.post(row_path)
    assert twice.value.status == 409

    replacement = run_session(pi, client, study_id, random.Random(3))
    overview = pi.get(f"/api/pi/overview?study={study_id}")
    rows = {s["participant"]: s["plan_row"] for s in overview["sessions"]}
    assert rows[replacement.participant_code] == row_number  # the dropout's row, not the next
    assert rows[code] == row_number  # the dropout's session still names the row it ran
    assert overview["progress"]["dropped_out"] == 1
    assert overview["progress"]["replaced"] == 1
    assert overview["balance"]["participants"] == 2  # the two complete rows
    participants = {r["participant"]: r for r in table(client, study_id, "participants")}
    assert participants[code]["plan_row"] == str(row_number)
    assert participants[code]["end_reason"] == "participant_withdrew"
    assert participants[replacement.participant_code]["plan_row"] == str(row_number)


def test_a_registered_participant_who_never_came_can_be_replaced(
    client: TestClient, pi: StaffApi
) -> None:
    study_id = study_with_plan(pi, participants=3)
    no_show = WizardBot.create(pi, study_id)
    code = no_show.snapshot["participant"]["code"]
    overview = pi.get(f"/api/pi/overview?study={study_id}")
    row = next(s for s in overview["sessions"] if s["participant"] == code)
    assert {flag["kind"] for flag in row["flags"]} == {"not_started"}
    assert row["can_hand_on"] is True
    page = client.get("/pi", params={"study": study_id}).text
    assert f"Give row {row['plan_row']} to a replacement" in page
    assert 'data-flag="not_started"' in page
    pi.post(f"/api/pi/participants/{code}/hand-on-row?study={study_id}")
    nxt = WizardBot.create(pi, study_id)
    assert nxt.snapshot["participant"]["code"] != code


def test_forms_for_exclude_include_and_hand_on(client: TestClient, pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=3)
    code = run_session(pi, client, study_id, random.Random(2)).participant_code
    form = client.get(f"/pi/participants/{code}/exclude", params={"study": study_id})
    assert form.status_code == 200
    assert f"Exclude participant {code}" in form.text
    token = pi.csrf
    empty = client.post(
        f"/pi/participants/{code}/exclude",
        params={"study": study_id},
        data={"reason": "", "csrf_token": token},
    )
    assert empty.status_code == 400
    assert "Give the reason" in empty.text
    done = client.post(
        f"/pi/participants/{code}/exclude",
        params={"study": study_id},
        data={"reason": "fell asleep", "csrf_token": token},
        follow_redirects=True,
    )
    assert "is excluded from the analysis (fell asleep); no data deleted" in done.text
    assert "Include again" in done.text
    assert "Give row 1 to a replacement" in done.text
    handed = client.post(
        f"/pi/participants/{code}/hand-on-row",
        params={"study": study_id},
        data={"csrf_token": token},
        follow_redirects=True,
    )
    assert "Plan row 1 goes to the next participant registered" in handed.text
    included = client.post(
        f"/pi/participants/{code}/include",
        params={"study": study_id},
        data={"csrf_token": token},
        follow_redirects=True,
    )
    assert "is included in the analysis again" in included.text
    no_csrf = client.post(f"/pi/participants/{code}/include", params={"study": study_id})
    assert no_csrf.status_code == 403


def test_wizards_cannot_exclude(client: TestClient, engine: Engine, pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=2)
    code = run_session(pi, client, study_id, random.Random(2)).participant_code
    client.post("/logout", headers={"X-CSRF-Token": pi.csrf})
    wizard = staff_api(client, engine, "wizard")
    with pytest.raises(ApiError) as refused:
        wizard.post(
            f"/api/pi/participants/{code}/exclusion?study={study_id}",
            {"excluded": True, "reason": "x"},
        )
    assert refused.value.status == 403
