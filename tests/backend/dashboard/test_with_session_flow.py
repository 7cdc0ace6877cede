"""Dashboard, export, analysis and withdrawal on data the real session flow produced
(the scripted wizard and participant drive sessions through the public API)."""

from __future__ import annotations

import csv
import io
import json
import random
import shutil
import zipfile
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, select

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import Base
from tests.support.bots import run_session, staff_api, study_with_plan


@pytest.fixture
def database_url(sqlite_template: Path, tmp_path: Path) -> str:
    """An integration walk over the whole flow; the per-database behaviour (withdrawal,
    export queries) is covered on both backends by the other tests, so SQLite is enough."""
    path = tmp_path / "flow.sqlite3"
    shutil.copyfile(sqlite_template, path)
    return f"sqlite:///{path}"


def test_sessions_run_by_the_flow_export_analyse_and_withdraw(
    client: TestClient, engine: Engine
) -> None:
    pi = staff_api(client, engine, "pi")
    study_id = study_with_plan(pi, participants=6)
    codes = [run_session(pi, client, study_id, random.Random(n)).participant_code for n in range(3)]
    run_session(pi, client, study_id, random.Random(9), rehearsal=True)

    overview = client.get("/api/pi/overview", params={"study": study_id}).json()
    assert overview["progress"]["used"] == 3
    assert overview["balance"]["participants"] == 3
    assert {s["participant"] for s in overview["sessions"]} >= set(codes)
    assert all(s["flags"] == [] for s in overview["sessions"]), overview["sessions"]
    session_id = overview["sessions"][0]["session"]
    assert client.get(f"/pi/sessions/{session_id}").status_code == 200

    bundle = client.get("/api/pi/export.zip", params={"study": study_id})
    archive = zipfile.ZipFile(io.BytesIO(bundle.content))

    def table(name: str) -> list[dict[str, str]]:
        return list(csv.DictReader(io.StringIO(archive.read(f"{name}.csv").decode())))

    assert sorted({row["participant"] for row in table("participants")}) == sorted(codes)
    interactions = table("interactions")
    assert len(interactions) == 9
    assert all(row["initial_ranking"] and row["final_error"] for row in interactions)
    assert len(table("suggestions")) == 27
    scores = table("scores")
    assert len(scores) == 9
    assert all(row["credibility"] and row["likeability"] and row["trust"] for row in scores)
    assert any(row["kind"] == "suggestion.decided" for row in table("events"))

    analysis = client.get("/api/pi/analysis", params={"study": study_id}).json()
    assert analysis["error"] is None
    assert analysis["analysis"]["measures"]["accepted"]["friedman"]["n"] == 3

    token = pi.csrf
    gone = codes[1]
    response = client.post(
        f"/api/pi/participants/{gone}/withdraw",
        params={"study": study_id},
        json={"confirm": gone},
        headers={"X-CSRF-Token": token},
    )
    assert response.status_code == 200, response.text
    with session_scope(build_sessionmaker(engine)) as db:
        everything = {
            t.name: [dict(r._mapping) for r in db.execute(select(t))]
            for t in Base.metadata.sorted_tables
        }
        assert gone not in json.dumps(everything, default=str)
