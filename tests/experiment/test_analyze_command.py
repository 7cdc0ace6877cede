"""``chameleons analyze`` on a scores.csv file."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from chameleons.cli.main import cli
from chameleons.experiment.study import load_default_study
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
    # The exact permutation p is there without asking (12 participants, 3 conditions).
    permutation = data["measures"]["accepted"]["friedman"]["permutation"]
    assert permutation["method"] == "exact"
    assert data["measures"]["accepted"]["friedman"]["primary"]["p"] == permutation["p"]


def test_analyze_text_latex_and_permutations(tmp_path: Path) -> None:
    scores = write_scores(tmp_path / "scores.csv", score_rows())
    code, out, _ = run("analyze", "--scores", str(scores), "--permutations", "200")
    assert code == 0
    assert "Friedman tests" in out
    assert "exact permutation p = 0.8981" in out
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
    assert "line 6 (participant 2, condition copy), column trust: 'lots' is not a number" in err
    assert "Traceback" not in err
    no_condition = [{"participant": r["participant"], "trust": r["trust"]} for r in score_rows()]
    code, _, err = run("analyze", "--scores", str(write_scores(tmp_path / "x.csv", no_condition)))
    assert code == 1
    assert "missing column(s) condition" in err
    code, _, err = run("analyze", "--scores", str(tmp_path / "x.csv"), "--permutations", "0")
    assert code == 2


REFUSALS = [
    # (row index, column, value, what the sentence must say)
    (4, "trust", "inf", "'inf' is not a finite number (leave the cell empty, or write NA"),
    (4, "trust", "NaN", "'NaN' is not a finite number"),
    (4, "accepted", "4", "'4' is outside 0..3 (accepted suggestions (of 3) takes whole numbers"),
    (4, "accepted", "-1", "'-1' is outside 0..3"),
    (4, "accepted", "2.5", "'2.5' is not a whole number"),
    (4, "credibility", "7.5", "'7.5' is outside 1..7 (the Credibility score"),
    (4, "likeability", "0", "'0' is outside 1..7"),
    # A score is the mean of the scale's whole-number answers: 12 credibility items give
    # multiples of 1/12 (53/12 = 4.4167), so 4.42 (a rounded or typed score) is impossible.
    (
        4,
        "credibility",
        "4.42",
        "'4.42' is not a mean of 12 whole-number answers (the nearest are 53/12 = 4.4167 and "
        "54/12 = 4.5000)",
    ),
    (4, "trust", "5.1", "'5.1' is not a mean of 6 whole-number answers"),
    (
        4,
        "condition",
        "Copy",
        "'Copy' is not a condition of the study (still, natural, copy); "
        "did you mean 'copy'? Labels are case-sensitive",
    ),
]


@pytest.mark.parametrize(("index", "column", "value", "sentence"), REFUSALS)
def test_each_impossible_value_is_refused_with_row_column_and_value(
    tmp_path: Path, index: int, column: str, value: str, sentence: str
) -> None:
    rows = score_rows()
    rows[index][column] = value
    code, out, err = run("analyze", "--scores", str(write_scores(tmp_path / "s.csv", rows)))
    assert code == 1, out
    assert f"line {index + 2} (participant 2" in err
    assert sentence in err
    assert "Nothing was analysed" in err
    assert "Traceback" not in err


def test_duplicate_participant_condition_rows_are_refused(tmp_path: Path) -> None:
    rows = score_rows()
    rows.append(dict(rows[1]))  # participant 1, copy, again
    code, _, err = run("analyze", "--scores", str(write_scores(tmp_path / "s.csv", rows)))
    assert code == 1
    assert "lines 3 and 38: participant 1 has copy twice" in err


def test_exported_means_are_on_the_grid(tmp_path: Path) -> None:
    """The export writes a mean as Python's repr of the double (53/12 as 4.416666666666667,
    4.5, 7): those pass, so does a mean written with a few more digits than the double."""
    rows = score_rows()
    rows[4]["credibility"] = repr(53 / 12)
    rows[5]["trust"] = "4.16666666666666696272613990004"  # 25/6 to 30 digits
    code, _, err = run("analyze", "--scores", str(write_scores(tmp_path / "s.csv", rows)))
    assert code == 0, err


def test_empty_and_na_cells_are_missing_not_refused(tmp_path: Path) -> None:
    rows = score_rows()
    rows[0]["trust"] = ""
    rows[1]["trust"] = "NA"
    code, out, _ = run("analyze", "--scores", str(write_scores(tmp_path / "s.csv", rows)))
    assert code == 0
    assert "1 left out of trust: no value for natural, copy" in out


def test_the_study_config_beside_the_scores_sets_conditions_and_scales(tmp_path: Path) -> None:
    rows = score_rows()
    write_scores(tmp_path / "scores.csv", rows)
    code, _, err = run("analyze", "--scores", str(tmp_path / "scores.csv"))
    assert code == 0
    assert "no study_config.json beside" in err  # the built-in study, said so
    spec = load_default_study().config
    five = {**spec, "suggestions_per_interaction": 5}
    (tmp_path / "study_config.json").write_text(json.dumps(five), encoding="utf-8")
    rows[4]["accepted"] = 5  # impossible with 3 suggestions, possible with 5
    write_scores(tmp_path / "scores.csv", rows)
    code, _out, err = run("analyze", "--scores", str(tmp_path / "scores.csv"))
    assert code == 0, err
    assert "study_config.json" not in err
    code, _, err = run(
        "analyze", "--scores", str(tmp_path / "scores.csv"), "--study-config",
        str(tmp_path / "missing.json"),
    )  # fmt: skip
    assert code == 1
    assert "cannot use" in err


def test_views_and_excluded_participants(tmp_path: Path) -> None:
    rows = score_rows()
    for row in rows:
        row.update(planned_condition=row["condition"], deviation="false", excluded="false")
        row["exclusion_reason"] = ""
    # Participant 3 ran copy twice (a switch to a condition already run)...
    natural, copy = rows[6], rows[7]
    assert (natural["participant"], natural["condition"], copy["condition"]) == (
        "3", "natural", "copy"
    )  # fmt: skip
    natural.update(condition="copy", deviation="true")
    # ... and participant 5 was excluded by the PI.
    for row in rows[12:15]:
        row.update(excluded="true", exclusion_reason="fell asleep")
    path = write_scores(tmp_path / "scores.csv", rows)
    code, out, _ = run("analyze", "--scores", str(path), "--format", "json")
    assert code == 0
    planned = json.loads(out)
    assert planned["view"] == "as_planned"
    assert planned["left_out"] == [
        {"participant": "5", "reason": "excluded by the PI: fell asleep"}
    ]
    assert planned["measures"]["trust"]["friedman"]["n"] == 11
    code, out, _ = run("analyze", "--scores", str(path), "--format", "json", "--view", "as_run")
    assert code == 0
    run_view = json.loads(out)
    assert [o["participant"] for o in run_view["left_out"]] == ["3", "5"]
    assert (
        "deviation from the plan (line 8 ran copy, planned natural)"
        in run_view["left_out"][0]["reason"]
    )
    assert run_view["measures"]["trust"]["friedman"]["n"] == 10
    code, out, _ = run("analyze", "--scores", str(path))
    assert "2 in the data" not in out
    assert "12 participants in the data; 1 left out" in out


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
    labels = [c.label for c in study.conditions]
    header = next(line for line in out.splitlines() if all(x in line for x in labels))
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
