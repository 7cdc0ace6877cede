"""``chameleons analyze`` on a scores.csv file."""

from __future__ import annotations

import csv
import json
from pathlib import Path

from click.testing import CliRunner

from chameleons.cli.main import cli
from tests.experiment.test_analysis import score_rows


def write_scores(path: Path, rows: list[dict[str, object]]) -> Path:
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return path


def run(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(cli, list(args))
    return result.exit_code, result.stdout, result.stderr


def test_analyze_json(tmp_path: Path) -> None:
    scores = write_scores(tmp_path / "scores.csv", score_rows())
    code, out, _ = run("analyze", "--scores", str(scores), "--format", "json")
    assert code == 0
    data = json.loads(out)
    assert set(data["measures"]) == {"accepted", "credibility", "likeability", "trust"}
    assert round(data["measures"]["accepted"]["friedman"]["chi2"], 2) == 0.25
    assert data["measures"]["accepted"]["friedman"]["permutation"] is None


def test_analyze_text_latex_and_permutations(tmp_path: Path) -> None:
    scores = write_scores(tmp_path / "scores.csv", score_rows())
    code, out, _ = run("analyze", "--scores", str(scores), "--permutations", "200")
    assert code == 0
    assert "Friedman tests" in out
    assert "permutation p (exact)" in out
    code, out, _ = run("analyze", "--scores", str(scores), "--format", "latex")
    assert code == 0
    assert r"\multirow{3}*{Credibility}" in out
    assert r"\begin{tabular}" in out


def test_analyze_reports_bad_input_readably(tmp_path: Path) -> None:
    code, _, err = run("analyze", "--scores", str(tmp_path / "missing.csv"))
    assert code == 1
    assert "cannot read" in err
    rows = score_rows()
    rows[4]["trust"] = "lots"
    code, _, err = run("analyze", "--scores", str(write_scores(tmp_path / "bad.csv", rows)))
    assert code == 1
    assert "row 5, trust: 'lots' is not a number" in err
    assert "Traceback" not in err
    no_condition = [{"participant": r["participant"], "trust": r["trust"]} for r in score_rows()]
    code, _, err = run("analyze", "--scores", str(write_scores(tmp_path / "x.csv", no_condition)))
    assert code == 1
    assert "missing column(s) condition" in err
    code, _, err = run("analyze", "--scores", str(tmp_path / "x.csv"), "--permutations", "0")
    assert code == 2


def test_analyze_json_has_effect_sizes_and_models(tmp_path: Path) -> None:
    # Positions rotate across participants (a Latin square), so they are not the conditions.
    rows = [{**row, "position": 1 + (i + i // 3) % 3} for i, row in enumerate(score_rows())]
    scores = write_scores(tmp_path / "scores.csv", rows)
    code, out, _ = run("analyze", "--scores", str(scores), "--format", "json", "--bootstrap", "300")
    assert code == 0
    data = json.loads(out)
    trust = data["measures"]["trust"]["effect_sizes"]
    assert trust["resamples"] == 300
    assert trust["kendall_w"]["ci_low"] is not None
    assert set(data["models"]["scores"]) == {"credibility", "likeability", "trust"}
    # No suggestions.csv beside scores.csv: the acceptance model says what it needs.
    assert data["models"]["acceptance"] is None
    assert "per-suggestion rows" in data["models"]["notes"][0]
    code, out, _ = run("analyze", "--scores", str(scores), "--format", "json", "--seed", "4",
                       "--bootstrap", "300")  # fmt: skip
    other = json.loads(out)["measures"]["trust"]["effect_sizes"]["kendall_w"]
    assert other["estimate"] == trust["kendall_w"]["estimate"]
    assert other["ci_high"] != trust["kendall_w"]["ci_high"]
    code, out, _ = run(
        "analyze", "--scores", str(scores), "--format", "json", "--bootstrap", "0", "--no-models"
    )
    data = json.loads(out)
    assert data["models"] is None
    assert data["measures"]["trust"]["effect_sizes"] is None
    code, out, _ = run("analyze", "--scores", str(scores), "--bootstrap", "300")
    assert "Effect sizes (95% bootstrap intervals" in out
    assert "trust: trust ~ C(condition) + C(position) + (1 | participant)" in out
    code, out, _ = run(
        "analyze", "--scores", str(scores), "--format", "latex", "--bootstrap", "300"
    )
    assert r"\label{tab:effects}" in out
    assert r"\label{tab:models}" in out
