"""Power planning and the preregistration: the CLI, the PI page (a real spawned worker
process) and the document's contents."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
from pathlib import Path

from click.testing import CliRunner
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.planning import service
from chameleons.cli.main import cli
from chameleons.experiment.study import canonical_json, load_default_study
from tests.backend.test_auth import add_user, login
from tests.support.factories import create_plan, create_study

STUDY_YAML = Path(__file__).parents[3] / "chameleons/experiment/studies/default/study.yaml"
QUICK = "n=12&replicates=100&model_replicates=3"


def run(*args: str, env: dict[str, str] | None = None) -> tuple[int, str, str]:
    result = CliRunner(env=env).invoke(cli, list(args))
    return result.exit_code, result.stdout, result.stderr


def test_power_command_json_and_text(tmp_path: Path) -> None:
    effects = ["--accept", "still=0.4", "--accept", "natural=0.4", "--accept", "copy=0.7",
               "--score", "still=4", "--score", "natural=4", "--score", "copy=5"]  # fmt: skip
    code, out, err = run("power", "--format", "json", "--n", "12,24", "--replicates", "300",
                         "--model-replicates", "4", *effects)  # fmt: skip
    assert code == 0, err
    data = json.loads(out)
    assert [row["n"] for row in data["rows"]] == [12, 24]
    assert data["rows"][0]["accepted_model"]["replicates"] == 4
    assert data["settings"]["tests"] == 4  # the paper's four measures
    assert data["design"]["balance_period"] == 12
    assert data["design"]["plan_seed"] == 0
    assert data["assumptions"]["acceptance"]["copy"] == 0.7
    assert "simulating" in err  # progress goes to stderr, the result to stdout
    (tmp_path / "power.json").write_text(out)
    code, out, _ = run("power", "--n", "12", "--replicates", "200", "--model-replicates", "0")
    assert code == 0
    assert "| 12 |" in out
    assert "effects not given are the paper's pilot estimates" in out
    assert "not simulated" in out  # no acceptance-model studies asked for


def test_power_command_refuses_bad_input_readably() -> None:
    code, _, err = run("power", "--accept", "copy=lots")
    assert code == 2
    assert "'copy=lots': use CONDITION=NUMBER" in err
    code, _, err = run("power", "--accept", "copy=0.5", "--score", "copy=4")
    assert code == 1
    assert "no value for condition(s) still, natural" in err
    code, _, err = run("power", "--n", "12,x")
    assert code == 2
    assert "use e.g. 12,24,36" in err


def test_preregistration_from_a_study_file_with_power(tmp_path: Path) -> None:
    _, power, _ = run("power", "--format", "json", "--n", "12", "--replicates", "100",
                      "--model-replicates", "0")  # fmt: skip
    (tmp_path / "power.json").write_text(power)
    out = tmp_path / "prereg.md"
    code, _, err = run("prereg", "--study", str(STUDY_YAML), "--participants", "24",
                       "--plan-seed", "7", "--power", str(tmp_path / "power.json"),
                       "--out", str(out))  # fmt: skip
    assert code == 0, err
    text = out.read_text()
    for heading in ("## Hypotheses", "## Design", "## Sampling plan", "## Variables",
                    "## Analysis plan", "## Appendix: study configuration"):  # fmt: skip
        assert heading in text
    for number, measure in enumerate(["accepted suggestions", "credibility", "likeability",
                                      "trust"], start=1):  # fmt: skip
        assert f"- H{number} ({measure})" in text
    assert "Planned sample size: **24 participants**" in text
    assert "- Plan seed: 7" in text
    assert "| 12 |" in text  # the power table
    assert "Bonferroni over the 4 measures" in text
    # The analysis plan: exact permutation p; the acceptance model's total effect (no kind).
    assert "its p-value is the exact permutation p" in text
    assert "`accepted ~ condition + position + item set` (the condition's total effect)" in text
    assert "item set + kind" not in text
    # The design states the study's own suggestion rule (the default: the paper's sentence
    # read literally, each misplaced item moved to its place, random only when none is).
    assert "to its place (preferring a move that lowers the ranking's error" in text
    assert "made only when every item the participant has not declined is at its place" in text
    up_only = tmp_path / "up_only.yaml"
    up_only.write_text(STUDY_YAML.read_text().replace("suggestion_rule: expert_place",
                                                      "suggestion_rule: up_only"))  # fmt: skip
    code, up_text, err = run("prereg", "--study", str(up_only), "--participants", "24")
    assert code == 0, err
    assert "most important item below its expert position up to it" in up_text
    assert "made only when no move up lowers the error" in up_text
    assert "to its place (preferring" not in up_text
    # The appendix holds the configuration itself: it hashes to the hash the header names.
    config = json.loads(re.search(r"```json\n(.*?)\n```", text, re.S).group(1))  # type: ignore[union-attr]
    digest = hashlib.sha256(canonical_json(config).encode()).hexdigest()
    assert digest == load_default_study().content_hash
    assert f"`{digest}`" in text
    code, _, err = run("prereg", "--study", str(STUDY_YAML))
    assert code == 1
    assert "--study needs --participants" in err
    (tmp_path / "bad.json").write_text("[]")
    code, _, err = run("prereg", "--power", str(tmp_path / "bad.json"))
    assert "is not the output of 'chameleons power --format json'" in err


def test_preregistration_from_the_database(sqlite_template: Path, tmp_path: Path) -> None:
    database = tmp_path / "study.sqlite3"
    shutil.copyfile(sqlite_template, database)
    engine = build_engine(f"sqlite:///{database}")
    with session_scope(build_sessionmaker(engine)) as db:
        study = create_study(db)
        study.plan_seed = 1234
        create_plan(db, study, load_default_study(), 36, seed=1234)
    engine.dispose()
    env = {k: v for k, v in os.environ.items() if not k.startswith("CHAMELEONS_")}
    env["CHAMELEONS_DATABASE_URL"] = f"sqlite:///{database}"
    code, out, err = run("prereg", env=env)
    assert code == 0, err
    assert "Planned sample size: **36 participants**" in out
    assert "- Plan seed: 1234" in out
    assert "No power computation attached" in out
    code, _, err = run("prereg", "--study-id", "9", env=env)
    assert code == 1
    assert "there is no study with id 9" in err


def _pi_with_study(client: TestClient, engine: Engine) -> int:
    with session_scope(build_sessionmaker(engine)) as db:
        study = create_study(db)
        create_plan(db, study, load_default_study(), 12, seed=study.plan_seed)
        study_id = study.id
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    service.results.clear()
    return study_id


def test_power_page_simulates_in_a_worker_process_and_feeds_the_preregistration(
    client: TestClient, engine: Engine
) -> None:
    study_id = _pi_with_study(client, engine)
    form = client.get(f"/pi/power?study={study_id}")
    assert form.status_code == 200
    assert 'name="accept_copy" value="0.500"' in form.text  # the paper's pilot
    assert 'id="power-table"' not in form.text
    page = client.get(f"/pi/power?study={study_id}&run=1&{QUICK}")
    assert page.status_code == 200, page.text
    assert '<tr data-n="12">' in page.text
    assert 'id="power-needed"' in page.text
    json_result = client.get(f"/api/pi/power?study={study_id}&run=1&{QUICK}").json()
    assert json_result["rows"][0]["n"] == 12
    assert json_result["rows"][0]["accepted_model"]["replicates"] == 3
    prereg = client.get(f"/pi/prereg.md?study={study_id}&run=1&{QUICK}")
    assert prereg.headers["content-type"].startswith("text/markdown")
    assert "attachment" in prereg.headers["content-disposition"]
    assert "Planned sample size: **12 participants**" in prereg.text
    assert "| 12 |" in prereg.text
    plain = client.get(f"/pi/prereg.md?study={study_id}").text
    assert "No power computation attached" in plain


def test_power_page_explains_bad_values_and_a_busy_simulator(
    client: TestClient, engine: Engine
) -> None:
    study_id = _pi_with_study(client, engine)
    bad = client.get(f"/pi/power?study={study_id}&run=1&accept_copy=1.5&n=12,x&alpha=nope")
    assert bad.status_code == 422
    assert "P(accept) for Copy must be between 0.001 and 0.999 (got 1.5)." in bad.text
    assert "Sample sizes: &#39;12,x&#39; is not a list of whole numbers" in bad.text
    assert 'value="1.5"' in bad.text  # what the PI typed stays in the form
    assert client.get(f"/api/pi/power?study={study_id}&accept_copy=2").status_code == 422
    assert service._running.acquire(blocking=False)
    try:
        busy = client.get(f"/pi/power?study={study_id}&run=1&{QUICK}&seed=99")
    finally:
        service._running.release()
    assert "another power simulation is running" in busy.text
    assert client.get(f"/api/pi/power?study={study_id}&run=1&{QUICK}&seed=98").status_code == 200


def test_planning_pages_need_a_pi(client: TestClient, engine: Engine) -> None:
    add_user(engine, "wiz", "right password", "wizard")
    login(client, "wiz", "right password")
    for url in ("/pi/power", "/api/pi/power", "/pi/prereg.md"):
        assert client.get(url).status_code == 403, url
