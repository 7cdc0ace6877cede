"""Every number on the analysis page traces back to the export: the page rebuilt from the
exported files alone (study_config.json, scores.csv, suggestions.csv, interactions.csv,
metadata.json) is the same page, character for character, in both views, with an
excluded participant, a session ended early and a condition switched against the plan."""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, select

from chameleons.backend.analysis import pages
from chameleons.backend.analysis.service import StudyAnalysis, StudyScores, run_analysis
from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.dropouts.service import exclude
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.models import Interaction, Session, Study
from chameleons.cli.analyze_command import (
    read_answers_beside,
    read_csv_rows,
    read_scores_csv,
    read_suggestions_beside,
)
from chameleons.experiment.stats import AnalysisError, error_score_table
from chameleons.experiment.stats.effect_sizes import BootstrapOptions
from chameleons.experiment.study import canonical_json, study_from_config
from tests.backend.analysis.test_missing_not_zero import database_url  # noqa: F401
from tests.support.bots import staff_api
from tests.support.factories import populate


def set_up(engine: Engine, effects: dict[str, float] | None = None) -> int:
    """12 participants: P003 excluded, P007's interaction 2 switched to interaction 1's
    condition (a deviation), P012 ended early during interaction 3; ``effects``: the
    conditions' effects on the answers (the factory's default: small)."""
    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, 12, seed=5, effects=effects)
        exclude(db, data.study_id, "P003", "fell asleep")
        sessions = dict(zip(data.codes, data.session_ids, strict=True))
        p7 = {i.position: i for i in db.scalars(
            select(Interaction).where(Interaction.session_id == sessions["P007"])
        )}  # fmt: skip
        p7[2].condition = p7[1].condition
        ended = db.get(Session, sessions["P012"])
        assert ended is not None
        ended.state, ended.end_reason = "ended", "technical_failure"
        last = db.scalars(
            select(Interaction).where(Interaction.session_id == ended.id, Interaction.position == 3)
        ).one()
        last.state = "negotiation"
        return data.study_id


def study_from_files(folder: Path) -> tuple[Study, Any]:
    """The study as the export describes it; its hash recomputed by the recipe."""
    metadata = json.loads((folder / "metadata.json").read_text("utf-8"))
    config = json.loads((folder / "study_config.json").read_text("utf-8"))
    recomputed = hashlib.sha256(canonical_json(config).encode("utf-8")).hexdigest()
    assert recomputed == metadata["study_config_hash"], metadata["study_config_hash_recipe"]
    study = Study(
        id=metadata["study"]["id"], name=metadata["study"]["name"], config=config,
        config_hash=recomputed, plan_seed=metadata["plan_seed"],
    )  # fmt: skip
    return study, study_from_config(config)


def analysis_from_files(folder: Path, view: Any, extended: bool, **options: Any) -> StudyAnalysis:
    """What ``study_analysis`` computes from the database, from the exported files."""
    study, spec = study_from_files(folder)
    scores_csv = folder / "scores.csv"
    answers = read_answers_beside(scores_csv) or []
    scores = StudyScores(study, spec, [dict(r) for r in read_scores_csv(scores_csv)], answers)
    suggestions = read_suggestions_beside(scores_csv) if extended else None
    bootstrap = BootstrapOptions() if extended else None
    try:
        result = run_analysis(
            scores, options.get("permutations"), 0, view, options["wilcoxon_rule"],
            suggestions, bootstrap,
        )  # fmt: skip
    except AnalysisError as exc:
        return StudyAnalysis(scores, None, f"The analysis cannot run: {exc}", {})
    interactions = read_csv_rows(folder / "interactions.csv", ("participant", "condition"))
    column = "planned_condition" if result.view == "as_planned" else "condition"
    kept = set(result.participants)
    rows = [{**r, "condition": r[column]} for r in interactions if r["participant"] in kept]
    return StudyAnalysis(scores, result, None, error_score_table(rows))


NONCE = re.compile(r'(nonce|csrf_token|value)="[^"]*"')


def page(client: TestClient, path: str) -> str:
    response = client.get(path)
    assert response.status_code == 200, response.text
    return NONCE.sub(r'\1=""', response.text)


@pytest.mark.parametrize("view", ["as_planned", "as_run"])
def test_the_analysis_page_is_rebuilt_from_the_export_alone(
    client: TestClient, engine: Engine, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    view: str,
) -> None:  # fmt: skip
    study_id = set_up(engine)
    staff_api(client, engine, "pi")
    folder = tmp_path / "export"
    with build_sessionmaker(engine)() as db:
        export_to_directory(db, ExportRequest(study_id=study_id), folder)
    query = f"?study={study_id}&view={view}"
    from_database = page(client, f"/pi/analysis{query}")
    extended_database = page(client, f"/pi/analysis/extended{query}")
    assert "P003" in from_database  # excluded, and why
    assert "fell asleep" in from_database
    numbers = re.findall(r"\d+\.\d+", from_database)
    assert len(numbers) > 20, "the page shows the analysis"

    def from_files(
        _db: Any, _study: Any, _rehearsal: Any, permutations: Any = None, view: Any = None,
        wilcoxon_rule: Any = None, *, extended: bool = True,
    ) -> StudyAnalysis:  # fmt: skip
        return analysis_from_files(
            folder, view, extended, permutations=permutations, wilcoxon_rule=wilcoxon_rule
        )

    monkeypatch.setattr(pages, "study_analysis", from_files)
    assert page(client, f"/pi/analysis{query}") == from_database
    assert page(client, f"/pi/analysis/extended{query}") == extended_database
