"""Wizard notes: free-text observations stamped on the timeline with where the session is,
refused readably when empty, exported in the events table and shown to the PI (real HTTP API,
both databases)."""

from __future__ import annotations

import csv
import io
import json
import random
import zipfile

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from tests.support.bots import ApiError, WizardBot, run_session, staff_api, study_with_plan


def notes(wizard: WizardBot) -> list[dict[str, object]]:
    events = wizard.staff.get(f"/api/sessions/{wizard.session_id}/events?limit=5000")
    return [e for e in events if e["kind"] == "wizard.note"]


def test_notes_carry_the_step_and_reach_the_export_and_the_pi(
    client: TestClient, engine: Engine
) -> None:
    pi = staff_api(client, engine, "pi")
    study_id = study_with_plan(pi, participants=3)
    wizard = WizardBot.create(pi, study_id)
    path = f"/api/sessions/{wizard.session_id}/notes"
    before = pi.post(path, {"text": "  participant arrived late  "})
    assert before["payload"] == {"text": "participant arrived late", "position": None,
                                 "step": "pending"}  # fmt: skip
    wizard.start()
    wizard.advance(1, "discussion")
    during = pi.post(path, {"text": "asked about the distance to the road"})
    assert during["payload"]["position"] == 1
    assert during["payload"]["step"] == "discussion"
    assert during["interaction_id"] is not None
    assert during["source"] == "wizard"
    assert [n["payload"]["text"] for n in notes(wizard)] == [  # type: ignore[index]
        "participant arrived late",
        "asked about the distance to the road",
    ]

    bundle = zipfile.ZipFile(io.BytesIO(
        client.get("/api/pi/export.zip", params={"study": study_id}).content))  # fmt: skip
    rows = list(csv.DictReader(io.StringIO(bundle.read("events.csv").decode())))
    exported = [r for r in rows if r["kind"] == "wizard.note"]
    assert len(exported) == 2
    assert "asked about the distance to the road" in json.dumps(exported)
    page = client.get(f"/pi/sessions/{wizard.session_id}")
    assert page.status_code == 200
    assert "asked about the distance to the road" in page.text


def test_empty_or_oversized_notes_are_refused_and_nothing_is_logged(
    client: TestClient, engine: Engine
) -> None:
    wizard_api = staff_api(client, engine, "pi")
    wizard = WizardBot.create(wizard_api, study_with_plan(wizard_api))
    path = f"/api/sessions/{wizard.session_id}/notes"
    for text, says in (("   ", "The note is empty"), ("x" * 2001, "at most 2000"),
                       ("a\x00b", "NUL character")):  # fmt: skip
        with pytest.raises(ApiError) as refused:
            wizard_api.post(path, {"text": text})
        assert refused.value.status == 422
        assert says in json.dumps(refused.value.detail)
    assert notes(wizard) == []
    no_csrf = client.post(path, json={"text": "hello"})
    assert no_csrf.status_code == 403
    unknown = wizard_api.http.post("/api/sessions/999999/notes", json={"text": "hello"},
                                   headers={"X-CSRF-Token": wizard_api.csrf})  # fmt: skip
    assert unknown.status_code == 404


def test_a_note_after_the_session_ended_is_still_taken(client: TestClient, engine: Engine) -> None:
    pi = staff_api(client, engine, "pi")
    result = run_session(pi, client, study_with_plan(pi, participants=3), random.Random(1))
    note = pi.post(f"/api/sessions/{result.session_id}/notes",
                   {"text": "said in the debriefing that copy felt creepy"})  # fmt: skip
    assert note["payload"]["step"] == "complete"
