"""Synchrony on the analysis page and in ``chameleons analyze`` (file and database modes)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from click.testing import CliRunner
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.synchrony import repository, service
from chameleons.cli.main import cli
from tests.backend.synchrony.recorded import recorded_study
from tests.backend.synchrony.test_analysis_r import fill_synchrony
from tests.backend.synchrony.test_service import PARAMS
from tests.backend.test_auth import add_user, login
from tests.support.factories import populate


def test_analyze_reads_the_synchrony_columns_beside_the_scores(
    db_session: Any, tmp_path: Path
) -> None:
    populate(db_session, 12, seed=6)
    db_session.flush()
    export_to_directory(db_session, ExportRequest(), tmp_path)
    fill_synchrony(tmp_path / "interactions.csv", seed=6)
    scores = str(tmp_path / "scores.csv")
    ran = CliRunner().invoke(cli, ["analyze", "--scores", scores, "--format", "json",
                                   "--bootstrap", "0"])  # fmt: skip
    assert ran.exit_code == 0, ran.output
    data = json.loads(ran.stdout)
    by_condition = {c["condition"]: c for c in data["synchrony"]["conditions"]}
    assert by_condition["copy"]["checks"] == {"ok": 12}
    assert by_condition["still"]["missing"] == {"robot_still": 12}
    assert data["synchrony"]["mimicry_model"]["n_observations"] == 24
    text = CliRunner().invoke(cli, ["analyze", "--scores", scores, "--bootstrap", "0"])
    assert text.exit_code == 0, text.output
    assert "Synchrony of the faces" in text.stdout
    assert "mimicry_z ~ C(condition) + C(position) + (1 | participant)" in text.stdout
    assert "credibility ~ C(condition) + C(position) + mimicry_z" in text.stdout


def test_the_analysis_page_shows_synchrony_by_condition(
    client: TestClient, engine: Engine, settings: Any
) -> None:
    data_dir = Path(settings.data_dir)
    with session_scope(build_sessionmaker(engine)) as db:
        study = recorded_study(db, data_dir, participants=2)
        for interaction_id in repository.interactions_of(db, study.study_id):
            service.compute(db, interaction_id, data_dir, PARAMS)
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    page = client.get("/pi/analysis", params={"study": study.study_id})
    source = f"/pi/analysis/synchrony?study={study.study_id}&amp;view=as_planned"
    assert f'data-src="{source}"' in page.text
    fragment = client.get("/pi/analysis/synchrony", params={"study": study.study_id})
    assert fragment.status_code == 200
    assert 'id="synchrony-by-condition"' in fragment.text
    assert "copy checks" in fragment.text.lower()
    assert '<tr data-condition="copy">' in fragment.text
    assert "ok 2" in fragment.text  # both copy interactions passed their check
    assert "robot still 2" in fragment.text
    assert "Mimicry as the outcome" in fragment.text
