"""The example study shipped beside the default (chameleons/experiment/studies/copy_delay):
four conditions (still, natural, copy 1 s, copy 4 s), two suggestions per interaction and
another final questionnaire run through `plan`, a rehearsal of 8 participants with a real
worker, the robot set-up, the export and the analysis, with no code written for it."""

from __future__ import annotations

import csv
import json
import secrets
from pathlib import Path

import pytest
from click.testing import CliRunner

from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.migrate import upgrade
from chameleons.backend.studies import service as studies
from chameleons.cli.analyze_command import analyze_command
from chameleons.cli.main import cli
from chameleons.experiment.study import load_study
from chameleons.rehearsal.embedded import embedded_system
from chameleons.rehearsal.runner import Options, rehearse
from chameleons.settings import Settings

EXAMPLE = Path(__file__).parents[2] / "chameleons/experiment/studies/copy_delay/study.yaml"
CONDITIONS = ["still", "natural", "copy_fast", "copy_slow"]


def read(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def test_the_example_loads_with_its_own_design() -> None:
    study = load_study(EXAMPLE)
    assert list(study.condition_ids) == CONDITIONS
    assert [(c.behaviour, c.params.get("delay")) for c in study.conditions[2:]] == [
        ("copy", 1.0), ("copy", 4.0)
    ]  # fmt: skip
    assert study.suggestions_per_interaction == 2
    assert study.measures == ("accepted", "likeability", "trust")
    final = [(i.id, i.type) for i in study.questionnaire("final").items]
    assert final[0] == ("favourite", "robot")
    assert study.warnings == ()


def test_plan_balances_eight_participants() -> None:
    result = CliRunner().invoke(
        cli, ["plan", "--study", str(EXAMPLE), "-n", "8", "--format", "json"]
    )
    assert result.exit_code == 0, result.output
    plan = json.loads(result.output)
    rows = plan["rows"]
    assert len(rows) == 8
    for row in rows:
        assert sorted(i["condition"] for i in row["interactions"]) == sorted(CONDITIONS)
    firsts = sorted(row["interactions"][0]["condition"] for row in rows)
    assert firsts == sorted(CONDITIONS * 2)  # each condition first twice (Williams design)


@pytest.mark.slow
def test_a_rehearsal_of_eight_runs_through_export_and_analysis(tmp_path: Path) -> None:
    settings = Settings(
        data_dir=tmp_path / "data", secret_key=secrets.token_urlsafe(32), _env_file=None
    )
    url = settings.effective_database_url
    upgrade(url)
    engine = build_engine(url)
    with session_scope(build_sessionmaker(engine)) as db:
        study = studies.create_study(db, load_study(EXAMPLE), 7)
        studies.generate_plan(db, study, 8)
        study_id = study.id
    engine.dispose()
    with embedded_system(settings, study_id, simulate_face=False) as target:
        summary = rehearse(target, Options(8, seed=3, pattern="effect", script="silent"))
    assert summary.codes == [f"R{n:03d}" for n in range(1, 9)]

    out = tmp_path / "export"
    env = {"CHAMELEONS_DATABASE_URL": url}
    runner = CliRunner(env=env)
    exported = runner.invoke(cli, ["export", "--include-rehearsal", "--out", str(out)])
    assert exported.exit_code == 0, exported.output
    interactions = read(out / "interactions.csv")
    assert len(interactions) == 8 * 4
    assert sorted({r["condition"] for r in interactions}) == sorted(CONDITIONS)
    assert {r["condition"]: r["behaviour"] for r in interactions} == {
        "still": "still", "natural": "natural", "copy_fast": "copy", "copy_slow": "copy"
    }  # fmt: skip
    assert len(read(out / "suggestions.csv")) == 8 * 4 * 2
    # The robot was set up with each condition's behaviour and parameters.
    applied = [r for r in read(out / "events.csv") if r["kind"] == "robot.applied"]
    delays = {
        json.loads(r["payload"])["condition"]: json.loads(r["payload"]).get("params", {})
        for r in applied
    }
    assert delays["copy_fast"]["delay"] == 1.0
    assert delays["copy_slow"]["delay"] == 4.0
    named = [r for r in read(out / "questionnaire.csv") if r["item"] == "favourite"]
    assert len(named) == 8
    assert all(r["named_condition"] in CONDITIONS for r in named)
    scores = read(out / "scores.csv")
    assert set(scores[0]) >= {"accepted", "likeability", "trust"}
    assert "credibility" not in scores[0]

    result = runner.invoke(
        analyze_command,
        ["--scores", str(out / "scores.csv"), "--format", "json", "--bootstrap", "200"],
    )
    assert result.exit_code == 0, result.output
    analysis = json.loads(result.output)
    assert analysis["conditions"] == CONDITIONS  # the study's order
    for measure in ("accepted", "likeability", "trust"):
        test = analysis["measures"][measure]["friedman"]
        assert (test["k"], test["df"], test["n"]) == (4, 3, 8)
        posthoc = analysis["measures"][measure]["posthoc"]
        assert len(posthoc) in (0, 6)  # all k(k-1)/2 pairs, when the Friedman test allows
    text = runner.invoke(analyze_command, ["--scores", str(out / "scores.csv")]).output
    assert "Accepted robot suggestions (0-2)" in text
    assert "p x 6 pairs" in text
    latex = runner.invoke(
        analyze_command, ["--scores", str(out / "scores.csv"), "--format", "latex"]
    ).output
    for label in ("Still", "Natural movement", "Copy 1 s", "Copy 4 s"):
        assert label in latex
