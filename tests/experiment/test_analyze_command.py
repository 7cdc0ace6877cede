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


def test_an_exported_study_config_beside_the_scores_gives_labels_ranges_and_order(
    tmp_path: Path,
) -> None:
    """A four-condition study with two suggestions: its own condition order and labels, and
    the accepted range 0-2, come from the export's study_config.json."""
    from chameleons.experiment.study import load_study
    from tests.experiment.study_files import four_condition_document, write_study

    document = four_condition_document()
    document["suggestions_per_interaction"] = 2
    study = load_study(write_study(tmp_path, document))
    (tmp_path / "study_config.json").write_text(json.dumps(study.config), "utf-8")
    rows = [
        {"participant": f"P{p:03d}", "condition": c, "position": n + 1,
         "accepted": (p + n) % 3, "credibility": 3 + (p * n) % 4, "likeability": 4,
         "trust": 2 + (p + 2 * n) % 5}
        for p in range(1, 9)
        for n, c in enumerate(study.condition_ids)
    ]  # fmt: skip
    scores = write_scores(tmp_path / "scores.csv", rows)
    code, out, _ = run("analyze", "--scores", str(scores))
    assert code == 0, out
    header = out.splitlines()[0]
    labels = [c.label for c in study.conditions]
    assert [header.index(label) for label in labels] == sorted(header.index(x) for x in labels)
    assert "Accepted robot suggestions (0-2)" in out
    assert "chi2(3)" in out  # k - 1 degrees of freedom
    assert "Bonferroni over 6 pairs" in out or "p x 6 pairs" in out
    code, latex, _ = run("analyze", "--scores", str(scores), "--format", "latex")
    assert r"\multirow{4}*{Trust}" in latex
    assert "suggestions (0-2)" in latex
    # A broken config beside the scores is a clear error, not a traceback.
    (tmp_path / "study_config.json").write_text('{"id": "x"}', "utf-8")
    code, out, err = run("analyze", "--scores", str(scores))
    assert code != 0
    assert "study_config.json" in (out + err)
