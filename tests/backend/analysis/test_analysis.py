"""The analysis from the database equals the analysis of the export; plots, page, LaTeX."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.analysis.plots import plot_measure
from chameleons.backend.analysis.service import database_scores, run_analysis, study_analysis
from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.cli.analyze_command import read_scores_csv
from chameleons.experiment.stats import analyze
from tests.backend.test_auth import add_user, login
from tests.support.factories import PopulatedStudy, populate


@pytest.fixture
def populated(db_session: DbSession) -> PopulatedStudy:
    data = populate(db_session, 12, rehearsals=2, seed=7)
    db_session.commit()
    return data


def read(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def test_export_round_trip_gives_the_same_numbers(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    export_to_directory(db_session, ExportRequest(), tmp_path)
    from_export = analyze(
        read_scores_csv(tmp_path / "scores.csv"),
        questionnaires=populated.spec.questionnaires,
        answers=read(tmp_path / "questionnaire.csv"),
    ).to_dict()
    from_database = run_analysis(database_scores(db_session)).to_dict()
    assert from_export == from_database
    assert [r["scale"] for r in from_database["reliability"]] == [
        "credibility", "likeability", "trust"
    ]  # fmt: skip
    assert all(r["n"] == 36 for r in from_database["reliability"])  # 12 people x 3 robots
    accepted = from_database["measures"]["accepted"]
    assert accepted["friedman"]["n"] == 12  # rehearsals left out
    assert set(from_database["measures"]) == {"accepted", "credibility", "likeability", "trust"}


def test_scores_agree_with_the_raw_answers_and_suggestions(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    """Recompute the scores from questionnaire.csv and suggestions.csv, independently."""
    export_to_directory(db_session, ExportRequest(), tmp_path)
    reverse = {
        (q.id, item.id) for q in populated.spec.questionnaires for item in q.items if item.reverse
    }
    sums: dict[tuple[str, str, str], list[int]] = {}
    for row in read(tmp_path / "questionnaire.csv"):
        if row["value"]:
            value = int(row["value"])
            if (row["questionnaire"], row["item"]) in reverse:
                value = 8 - value
            key = (row["participant"], row["condition"], row["questionnaire"])
            sums.setdefault(key, []).append(value)
    accepted: dict[tuple[str, str], int] = {}
    for row in read(tmp_path / "suggestions.csv"):
        pair = (row["participant"], row["condition"])
        accepted[pair] = accepted.get(pair, 0) + (row["accepted"] == "true")
    for row in read(tmp_path / "scores.csv"):
        who = (row["participant"], row["condition"])
        assert int(row["accepted"]) == accepted[who]
        for measure, items in (("credibility", 12), ("likeability", 10), ("trust", 6)):
            values = sums[(*who, measure)]
            assert len(values) == items
            assert float(row[measure]) == pytest.approx(sum(values) / items, abs=1e-12)


def test_rehearsals_join_only_when_asked(db_session: DbSession, populated: PopulatedStudy) -> None:
    counted = study_analysis(db_session)
    everyone = study_analysis(db_session, include_rehearsal=True)
    assert counted.analysis is not None
    assert everyone.analysis is not None
    assert counted.analysis.measures["trust"].friedman.n == 12
    assert everyone.analysis.measures["trust"].friedman.n == 14


def test_error_scores_per_condition(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    export_to_directory(db_session, ExportRequest(), tmp_path)
    by_condition: dict[str, list[int]] = {}
    for row in read(tmp_path / "interactions.csv"):
        ranking = row["final_ranking"].split(";")
        expert = populated.spec.expert_order(row["task"], ranking)
        error = sum(abs(i - expert.index(item)) for i, item in enumerate(ranking))
        assert int(row["final_error"]) == error
        by_condition.setdefault(row["condition"], []).append(error)
    table = study_analysis(db_session).errors
    assert set(table) == {"initial_error", "final_error", "error_change"}
    for condition, values in by_condition.items():
        assert table["final_error"][condition].mean == pytest.approx(sum(values) / len(values))


def test_plots_in_every_format(db_session: DbSession, populated: PopulatedStudy) -> None:
    scores = database_scores(db_session)
    analysis = run_analysis(scores)
    conditions = analysis.conditions
    trust = list(analysis.measures["trust"].values.values())
    accepted = list(analysis.measures["accepted"].values.values())
    assert len(trust) == 12
    labels = scores.condition_labels
    svg = plot_measure(trust, "trust", conditions, labels, (1, 7), "subtitle", "svg")
    assert b"<svg" in svg[:500]
    assert svg.count(b'id="line2d_') >= 12  # a line per participant (plus boxes' lines)
    assert plot_measure(accepted, "accepted", conditions, labels, (0, 3), fmt="png")[:8] == (
        b"\x89PNG\r\n\x1a\n"
    )
    assert plot_measure(trust, "trust", conditions, labels, (1, 7), fmt="pdf")[:5] == b"%PDF-"
    empty = plot_measure([], "trust", conditions, labels, (1, 7), fmt="svg")
    assert b"<svg" in empty[:500]


def _client_with_data(client: TestClient, engine: Engine, participants: int = 6) -> Any:
    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, participants)
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    return data


def test_analysis_page_json_latex_and_plot_downloads(client: TestClient, engine: Engine) -> None:
    data = _client_with_data(client, engine)
    page = client.get("/pi/analysis")
    assert page.status_code == 200
    for measure in ("accepted", "credibility", "likeability", "trust"):
        assert f'<tr data-measure="{measure}">' in page.text
        assert f"/pi/analysis/plots/{measure}.svg?study={data.study_id}" in page.text
    assert "\\begin{tabular}" in page.text
    assert 'data-column="error_change"' in page.text
    reliability = client.get("/api/pi/analysis").json()["analysis"]["reliability"]
    for result in reliability:  # the page shows the API's numbers, one row per scale
        assert f'<tr data-scale="{result["scale"]}">' in page.text
        assert f"[{result['ci_low']:.2f}, {result['ci_high']:.2f}]" in page.text
    latex = client.get("/pi/analysis/table1.tex")
    assert latex.text.startswith("% Analysed as planned")
    assert "% Friedman accepted" in latex.text
    assert "\\multirow" in latex.text
    api = client.get("/api/pi/analysis").json()
    assert api["analysis"]["measures"]["trust"]["friedman"]["n"] == 6
    assert api["latex"] == latex.text.rstrip("\n")
    for fmt, kind in (("svg", "image/svg+xml"), ("png", "image/png"), ("pdf", "application/pdf")):
        image = client.get(f"/pi/analysis/plots/likeability.{fmt}")
        assert image.status_code == 200
        assert image.headers["content-type"].startswith(kind)
    assert client.get("/pi/analysis/plots/nonsense.svg").status_code == 404
    assert client.get("/pi/analysis/plots/trust.gif").status_code == 422
    with_p = client.get("/api/pi/analysis", params={"permutations": 200}).json()
    assert with_p["analysis"]["measures"]["trust"]["friedman"]["permutation"] is not None


def test_analysis_without_data_explains_itself(client: TestClient, engine: Engine) -> None:
    from chameleons.backend.models import Study
    from chameleons.experiment.study import load_default_study

    spec = load_default_study()
    with session_scope(build_sessionmaker(engine)) as db:
        db.add(Study(name=spec.name, config=spec.config, config_hash=spec.content_hash))
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    page = client.get("/pi/analysis")
    assert page.status_code == 200
    assert "No counted sessions yet" in page.text
    assert client.get("/pi/analysis/table1.tex").status_code == 409
    assert json.loads(client.get("/api/pi/analysis").text)["analysis"] is None


def test_analysis_needs_a_pi(client: TestClient, engine: Engine) -> None:
    add_user(engine, "wiz", "right password", "wizard")
    login(client, "wiz", "right password")
    for url in ("/pi/analysis", "/api/pi/analysis", "/pi/analysis/plots/trust.svg"):
        assert client.get(url).status_code == 403, url
