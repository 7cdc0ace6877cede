"""An interaction that never ran, or whose suggestions were not all decided, is missing in
the export, the analysis and the plots: never a count of 0 (sessions run by the real
session flow through the HTTP API)."""

from __future__ import annotations

import csv
import io
import random
import shutil
import zipfile
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from tests.support.bots import ParticipantBot, WizardBot, run_session, staff_api, study_with_plan


@pytest.fixture
def database_url(sqlite_template: Path, tmp_path: Path, request: pytest.FixtureRequest) -> str:
    path = tmp_path / "flow.sqlite3"
    shutil.copyfile(sqlite_template, path)
    return f"sqlite:///{path}"


def tables(client: TestClient, study_id: int) -> dict[str, list[dict[str, str]]]:
    bundle = client.get("/api/pi/export.zip", params={"study": study_id})
    archive = zipfile.ZipFile(io.BytesIO(bundle.content))
    return {
        name[:-4]: list(csv.DictReader(io.StringIO(archive.read(name).decode())))
        for name in archive.namelist()
        if name.endswith(".csv")
    }


def test_unstarted_and_partial_interactions_are_missing_not_zero(
    client: TestClient, engine: Engine
) -> None:
    pi = staff_api(client, engine, "pi")
    study_id = study_with_plan(pi, participants=6)
    complete = [
        run_session(pi, client, study_id, random.Random(n), accept_probability=1.0)
        for n in range(3)
    ]
    unstarted = WizardBot.create(pi, study_id)  # registered, session opened, never started
    partial = WizardBot.create(pi, study_id)
    phone = ParticipantBot(client, partial.token)
    partial.start()
    partial.advance(1, "discussion")
    partial.advance(1, "ranking")
    phone.rank(random.Random(1))
    partial.advance(1, "negotiation")
    partial.decide(1, 1, True)  # one of three suggestions decided

    data = tables(client, study_id)
    by_code: dict[str, list[dict[str, str]]] = {}
    for row in data["scores"]:
        by_code.setdefault(row["participant"], []).append(row)
    for row in by_code[unstarted.snapshot["participant"]["code"]]:
        assert row["accepted"] == ""
        assert row["trust"] == ""
        assert (row["interaction_status"], row["session_status"]) == ("not_run", "not_started")
        assert row["suggestions_decided"] == "0"
    first, *rest = by_code[partial.snapshot["participant"]["code"]]
    assert (first["accepted"], first["suggestions_decided"]) == ("", "1")
    assert first["interaction_status"] == "partial"
    assert all(r["interaction_status"] == "not_run" for r in rest)
    for result in complete:
        assert {r["accepted"] for r in by_code[result.participant_code]} == {"3"}
    interactions = [
        r
        for r in data["interactions"]
        if r["participant"] == partial.snapshot["participant"]["code"]
    ]
    assert (interactions[0]["accepted"], interactions[0]["suggestions_decided"]) == ("", "1")

    analysis = client.get("/api/pi/analysis", params={"study": study_id}).json()["analysis"]
    accepted = analysis["measures"]["accepted"]
    assert accepted["friedman"]["n"] == 3
    assert {c: d["mean"] for c, d in accepted["conditions"].items()} == {
        "natural": 3.0, "copy": 3.0, "still": 3.0
    }  # fmt: skip
    code = unstarted.snapshot["participant"]["code"]
    assert any(
        note.startswith(f"{code} left out of accepted: no value for")
        and "(interaction not run)" in note
        for note in accepted["notes"]
    ), accepted["notes"]
    assert "(interaction only partly run)" in " ".join(accepted["notes"])
    assert "5 participants in the data" in analysis["summary"]
    page = client.get("/pi/analysis", params={"study": study_id}).text
    assert "3.0, 3.0 ± 0.0" in page
    assert "(interaction not run)" in page
