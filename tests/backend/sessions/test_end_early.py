"""Ending a session early: the wizard's API, what the phone sees, the timeline, the export,
the analysis and the dashboard (sessions driven through the real HTTP API, both databases)."""

from __future__ import annotations

import csv
import io
import random
import zipfile
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from tests.support.bots import (
    ApiError,
    ParticipantBot,
    StaffApi,
    WizardBot,
    run_session,
    staff_api,
    study_with_plan,
)


def export(client: TestClient, study_id: int) -> dict[str, list[dict[str, str]]]:
    bundle = zipfile.ZipFile(
        io.BytesIO(client.get("/api/pi/export.zip", params={"study": study_id}).content)
    )
    return {
        name[:-4]: list(csv.DictReader(io.StringIO(bundle.read(name).decode())))
        for name in bundle.namelist()
        if name.endswith(".csv")
    }


def into_negotiation(wizard: WizardBot, phone: ParticipantBot, position: int) -> None:
    wizard.advance(position, "discussion")
    wizard.advance(position, "ranking")
    phone.rank(random.Random(position))
    wizard.advance(position, "negotiation")


def finish(wizard: WizardBot, phone: ParticipantBot, position: int) -> None:
    wizard.negotiate(position, lambda _s: True)
    wizard.advance(position, "questionnaire")
    phone.answer_questionnaires(position, random.Random(position))


@pytest.fixture
def pi(client: TestClient, engine: Engine) -> StaffApi:
    return staff_api(client, engine, "pi")


def test_ended_during_interaction_two(client: TestClient, pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=6)
    for n in range(3):
        run_session(pi, client, study_id, random.Random(n))
    wizard = WizardBot.create(pi, study_id)
    phone = ParticipantBot(client, wizard.token)
    wizard.start()
    into_negotiation(wizard, phone, 1)
    finish(wizard, phone, 1)
    into_negotiation(wizard, phone, 2)
    wizard.decide(2, 1, False)

    snapshot = pi.post(
        f"/api/sessions/{wizard.session_id}/end",
        {"reason": "technical_failure", "note": "the robot's face froze"},
    )
    assert snapshot["state"] == "ended"
    assert snapshot["allowed"] == [{"action": "none", "why": "ended"}]
    assert snapshot["allowed_sentence"] == "Allowed now: nothing: the session was ended early."
    assert phone.state() == {"view": "ended"}
    with pytest.raises(ApiError) as refused:
        wizard.decide(2, 2, True)
    assert refused.value.status == 409
    with pytest.raises(ApiError) as again:
        pi.post(f"/api/sessions/{wizard.session_id}/end", {"reason": "time"})
    assert again.value.status == 409
    assert "already been ended" in str(again.value.detail)
    ended = [e for e in wizard.staff.get(f"/api/sessions/{wizard.session_id}/events")
             if e["kind"] == "session.ended_early"]  # fmt: skip
    assert len(ended) == 1
    assert ended[0]["payload"]["position"] == 2
    assert ended[0]["payload"]["step"] == "negotiation"
    assert ended[0]["interaction_id"] is not None  # the booth stops that recording

    code = snapshot["participant"]["code"]
    tables = export(client, study_id)
    participant = next(r for r in tables["participants"] if r["participant"] == code)
    assert (participant["status"], participant["session_state"]) == ("ended_early", "ended")
    assert participant["end_reason"] == "technical_failure"
    assert participant["end_note"] == "the robot's face froze"
    assert participant["ended_at"]
    scores = [r for r in tables["scores"] if r["participant"] == code]
    assert [r["interaction_status"] for r in scores] == ["complete", "partial", "not_run"]
    assert [r["suggestions_decided"] for r in scores] == ["3", "1", "0"]
    assert scores[0]["accepted"] == "3"
    assert scores[1]["accepted"] == scores[2]["accepted"] == ""
    assert {r["session_status"] for r in scores} == {"ended_early"}

    analysis = pi.get(f"/api/pi/analysis?study={study_id}")["analysis"]
    accepted = analysis["measures"]["accepted"]
    assert accepted["friedman"]["n"] == 3
    assert any(
        note.startswith(f"{code} left out of accepted")
        and "interaction only partly run" in note
        and "the session was ended early" in note
        for note in accepted["notes"]
    ), accepted["notes"]

    overview = pi.get(f"/api/pi/overview?study={study_id}")
    row = next(s for s in overview["sessions"] if s["participant"] == code)
    kinds = {flag["kind"]: flag["text"] for flag in row["flags"]}
    assert "ended_early" in kinds
    assert kinds["ended_early"] == (
        "ended early during interaction 2: technical failure (the robot's face froze); "
        "interaction 3 not run"
    )
    assert kinds["partial"] == "interaction 2: stopped in negotiation, 1 of 3 suggestions decided"
    assert overview["progress"]["ended_early"] == 1
    assert overview["balance"]["participants"] == 3  # complete sessions only
    page = client.get(f"/pi/sessions/{row['session']}").text
    assert "ended early" in page
    assert "session.ended_early" in page


def test_end_early_refusals_change_nothing(client: TestClient, pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=3)
    wizard = WizardBot.create(pi, study_id)
    path = f"/api/sessions/{wizard.session_id}/end"
    for body, status, text in [
        ({"reason": "bored"}, 422, "is not a reason to end a session"),
        ({"reason": "other"}, 422, "Say in a few words why"),
        ({"reason": "other", "note": "   "}, 422, "Say in a few words why"),
    ]:
        with pytest.raises(ApiError) as refused:
            pi.post(path, body)
        assert refused.value.status == status
        assert text in str(refused.value.detail)
        assert wizard.refresh()["state"] == "pending"
    # A registered participant who never comes can be ended too.
    assert pi.post(path, {"reason": "other", "note": "did not come"})["state"] == "ended"
    done = run_session(pi, client, study_id, random.Random(1))
    with pytest.raises(ApiError) as complete:
        pi.post(f"/api/sessions/{done.session_id}/end", {"reason": "time"})
    assert complete.value.status == 409
    assert "already complete" in str(complete.value.detail)


def test_the_phone_page_says_thank_you(client: TestClient, pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=2)
    wizard = WizardBot.create(pi, study_id)
    wizard.start()
    pi.post(f"/api/sessions/{wizard.session_id}/end", {"reason": "participant_withdrew"})
    page = client.get(wizard.phone_path)
    assert page.status_code == 410
    assert "Thank you" in page.text
    joined = client.post("/join", data={"code": wizard.snapshot["phone"]["short_code"]})
    assert joined.status_code == 404


def switch(pi: StaffApi, session_id: int, body: dict[str, Any]) -> dict[str, Any]:
    result: dict[str, Any] = pi.post(f"/api/sessions/{session_id}/condition", body)
    return result


def test_a_repeated_condition_needs_a_confirmation(client: TestClient, pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=6)
    for n in range(3):
        run_session(pi, client, study_id, random.Random(n))
    wizard = WizardBot.create(pi, study_id)
    phone = ParticipantBot(client, wizard.token)
    wizard.start()
    into_negotiation(wizard, phone, 1)
    finish(wizard, phone, 1)
    first = wizard.refresh()["interactions"][0]["condition"]
    second = wizard.interaction(2)["planned_condition"]
    with pytest.raises(ApiError) as refused:
        switch(pi, wizard.session_id, {"condition": first, "position": 2})
    assert refused.value.status == 409
    assert refused.value.detail == {
        "message": f"Interaction 1 already ran {first}: switching interaction 2 to {first} "
        f"gives this participant {first} twice and no {second}. Confirm it as a deviation "
        "from the plan to go ahead.",
        "confirm": "confirm_deviation",
    }
    assert wizard.refresh()["interactions"][1]["condition"] == second
    snapshot = switch(
        pi, wizard.session_id, {"condition": first, "position": 2, "confirm_deviation": True}
    )
    assert snapshot["interactions"][1]["condition"] == first
    events = pi.get(f"/api/sessions/{wizard.session_id}/events")
    switched = next(e for e in events if e["kind"] == "condition.switched")
    assert switched["payload"]["confirmed"] is True
    assert switched["payload"]["repeats_position"] == 1
    assert any(e["kind"] == "plan.deviation" for e in events)
    into_negotiation(wizard, phone, 2)
    finish(wizard, phone, 2)
    for position in (3,):
        into_negotiation(wizard, phone, position)
        finish(wizard, phone, position)
    phone.answer_questionnaires(0, random.Random(0))
    assert wizard.refresh()["state"] == "complete"

    code = wizard.snapshot["participant"]["code"]
    planned = pi.get(f"/api/pi/analysis?study={study_id}")
    assert planned["error"] is None  # never "has copy twice"
    assert planned["analysis"]["view"] == "as_planned"
    assert planned["analysis"]["measures"]["accepted"]["friedman"]["n"] == 4
    as_run = pi.get(f"/api/pi/analysis?study={study_id}&view=as_run")["analysis"]
    assert as_run["measures"]["accepted"]["friedman"]["n"] == 3
    assert as_run["left_out"] == [
        {
            "participant": code,
            "reason": f"deviation from the plan (interaction 2 ran {first}, planned {second})",
        }
    ]
    page = client.get("/pi/analysis", params={"study": study_id, "view": "as_run"}).text
    assert f"<strong>{code}</strong>: deviation from the plan" in page
    assert 'aria-current="true">as run (per protocol' in page
    overview = pi.get(f"/api/pi/overview?study={study_id}")
    row = next(s for s in overview["sessions"] if s["participant"] == code)
    assert "deviation" in {flag["kind"] for flag in row["flags"]}
