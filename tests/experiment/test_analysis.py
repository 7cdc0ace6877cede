"""The analysis from score rows: descriptives, corrections, exclusions, post-hoc, rendering."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest
from scipy import stats

from chameleons.experiment.stats import (
    AnalysisError,
    analyze,
    error_score_table,
    permutation_p,
    render_latex,
    render_text,
    score_questionnaire,
)
from chameleons.experiment.study import load_default_study
from tests.experiment.r_wilcox import r_wilcox_paired

CONDITIONS = ("natural", "copy", "still")
# Accepted suggestions constructed to be consistent with the paper's Table I row
# (medians 1.0/1.0/1.5, means 1.4/1.5/1.6, SDs 0.9) and its chi2 = 0.25.
ACCEPTED = {
    "natural": [2, 2, 1, 1, 3, 1, 3, 1, 1, 1, 1, 0],
    "copy": [1, 3, 1, 1, 2, 0, 1, 3, 2, 2, 1, 1],
    "still": [1, 2, 1, 1, 2, 2, 0, 2, 1, 3, 1, 3],
}


def score_rows(seed: int = 0, trust_shift: float = 0.0) -> list[dict[str, Any]]:
    """12 participants x 3 conditions; ``trust_shift`` makes copy's trust clearly higher.
    Scores are means of whole-number answers, as the default study's 12, 10 and 6 items
    give them (anything else is refused as impossible)."""
    rng = np.random.default_rng(seed)
    rows = []
    for p in range(12):
        for condition in CONDITIONS:
            bonus = trust_shift * (condition == "copy") + trust_shift / 2 * (condition == "still")
            rows.append(
                {
                    "participant": str(p + 1),
                    "condition": condition,
                    "accepted": ACCEPTED[condition][p],
                    "credibility": mean_of(rng.uniform(2, 6), 12),
                    "likeability": mean_of(rng.uniform(2, 6), 10),
                    "trust": mean_of(min(7.0, rng.uniform(1, 3) + bonus + p * 0.01), 6),
                }
            )
    return rows


def mean_of(value: float, items: int) -> float:
    """The mean of ``items`` whole-number answers nearest ``value``."""
    return round(float(value) * items) / items


def column(rows: list[dict[str, Any]], measure: str) -> np.ndarray:
    return np.array([[r[measure] for r in rows if r["condition"] == c] for c in CONDITIONS]).T


def test_descriptives_and_friedman_per_measure() -> None:
    rows = score_rows()
    analysis = analyze(rows)
    assert analysis.conditions == list(CONDITIONS)
    for measure in ("accepted", "credibility", "likeability", "trust"):
        data = column(rows, measure)
        result = analysis.measures[measure]
        for j, condition in enumerate(CONDITIONS):
            d = result.conditions[condition]
            assert d.n == 12
            assert d.median == pytest.approx(np.median(data[:, j]))
            assert d.mean == pytest.approx(np.mean(data[:, j]))
            assert d.sd == pytest.approx(np.std(data[:, j], ddof=1))
        reference = stats.friedmanchisquare(*data.T)
        assert result.friedman.chi2 == pytest.approx(reference.statistic)
        assert result.p_bonferroni == pytest.approx(min(1.0, 4 * reference.pvalue))
        assert result.friedman.kendall_w == pytest.approx(reference.statistic / 24)


def test_accepted_row_in_table_one_layout() -> None:
    analysis = analyze(score_rows())
    accepted = analysis.measures["accepted"]
    assert accepted.friedman.chi2 == pytest.approx(0.25)
    assert accepted.p_bonferroni == 1.0
    latex = render_latex(analysis)
    assert r"\multirow{3}*{Accepted robot suggestions}" in latex
    assert r"& Natural movement & 1.0 & $1.4\pm0.9$ \\" in latex
    assert r"& Copy & 1.0 & $1.5\pm0.9$ \\" in latex
    assert r"& Still & 1.5 & $1.6\pm0.9$ \\" in latex
    assert latex.index("Natural movement") < latex.index("Copy") < latex.index("Still")
    wide = render_latex(analysis, layout="wide")
    assert r"Accepted robot suggestions & 1.0, $1.4\pm0.9$ & 1.0, $1.5\pm0.9$" in wide


def test_posthoc_only_where_the_corrected_test_is_significant() -> None:
    rows = score_rows(trust_shift=3.0)
    analysis = analyze(rows)
    trust = analysis.measures["trust"]
    assert trust.p_bonferroni is not None
    assert trust.p_bonferroni < 0.05
    data = column(rows, "trust")
    assert [(t.a, t.b) for t in trust.posthoc] == [
        ("natural", "copy"), ("natural", "still"), ("copy", "still")
    ]  # fmt: skip
    for test, (i, j) in zip(trust.posthoc, [(0, 1), (0, 2), (1, 2)], strict=True):
        v, p, _ = r_wilcox_paired(list(data[:, i]), list(data[:, j]))
        assert p is not None
        assert test.v == v
        assert test.p == pytest.approx(p)
        assert test.p_bonferroni == pytest.approx(min(1.0, 3 * p))
    assert analysis.measures["accepted"].posthoc == []
    assert "not done" in analysis.measures["accepted"].posthoc_note


def test_participant_missing_a_condition_is_excluded_with_a_note() -> None:
    rows = [r for r in score_rows() if not (r["participant"] == "7" and r["condition"] == "copy")]
    rows[0]["trust"] = ""  # participant 1's natural trust is missing too
    analysis = analyze(rows)
    accepted, trust = analysis.measures["accepted"], analysis.measures["trust"]
    assert accepted.friedman.n == 11
    assert accepted.excluded == ["7"]
    assert "7 left out of accepted: no value for copy" in accepted.notes
    assert trust.excluded == ["1", "7"]
    assert trust.conditions["still"].n == 10


def test_all_tied_measure_is_undefined_everywhere() -> None:
    rows = score_rows()
    for row in rows:
        row["accepted"] = 2
    analysis = analyze(rows)
    accepted = analysis.measures["accepted"]
    assert accepted.friedman.chi2 is None
    assert accepted.p_bonferroni is None
    data = analysis.to_dict()["measures"]["accepted"]["friedman"]
    assert data["chi2"] is None
    assert data["defined"] is False
    assert "chi2 undefined" in render_text(analysis)


def test_json_shape_and_permutation_p() -> None:
    data = analyze(score_rows(), permutations=500).to_dict()
    json.dumps(data)
    accepted = data["measures"]["accepted"]
    assert set(accepted["conditions"]["copy"]) == {"n", "median", "mean", "sd"}
    friedman = accepted["friedman"]
    assert {"n", "chi2", "df", "p", "p_bonferroni", "kendall_w"} <= set(friedman)
    assert friedman["permutation"]["method"] == "exact"
    assert 0 < friedman["permutation"]["p"] <= 1
    assert isinstance(accepted["posthoc"], list)


def test_text_rendering_has_the_table_and_the_tests() -> None:
    text = render_text(analyze(score_rows(), permutations=100))
    assert "Natural movement" in text
    assert "1.0, 1.4 ± 0.9" in text
    assert "chi2(2) = 0.25" in text
    assert "exact permutation p = " in text


def test_the_exact_permutation_p_is_reported_by_default_and_gates_the_posthoc_tests() -> None:
    """At the paper's 12 participants the asymptotic chi-squared p is rough: the exact
    permutation p is computed without being asked for, leads the report, and decides the
    post-hoc tests. Here credibility's asymptotic p (0.0498) is below 0.05 and its exact p
    (0.0580) is not."""
    rows = score_rows()
    analysis = analyze(rows, measures=["credibility"])
    credibility = analysis.measures["credibility"]
    assert credibility.permutation is not None
    assert credibility.permutation.method == "exact"
    # The exact distribution itself is checked against SciPy's enumeration, brute force and
    # the published critical values in test_friedman.py.
    assert credibility.permutation.p == permutation_p(column(rows, "credibility").tolist()).p
    assert credibility.friedman.p is not None
    assert credibility.permutation.p is not None
    assert credibility.friedman.p < 0.05 < credibility.permutation.p
    assert credibility.posthoc == []
    assert credibility.posthoc_note == "not done: corrected Friedman p (exact permutation) >= 0.05"
    data = analysis.to_dict()["measures"]["credibility"]["friedman"]
    assert data["primary"] == {
        "p": credibility.permutation.p, "p_bonferroni": credibility.permutation.p,
        "method": "exact permutation",
    }  # fmt: skip
    line = next(x for x in render_text(analysis).splitlines() if x.strip().startswith("cred"))
    assert line.index("exact permutation p = 0.0580") < line.index("asymptotic chi-squared")


@pytest.mark.parametrize(
    ("participants", "warned"),
    [(1, ["only 1 participant", "too few"]), (2, ["too few"]), (3, ["too few"]), (4, [])],
)
def test_tiny_samples_are_warned_about(participants: int, warned: list[str]) -> None:
    """One participant gives W = 1 whatever they answered; below 4 participants no data can
    reach p < 0.05 / 4 with three conditions (the smallest exact p is 6^(1 - n))."""
    rows = [r for r in score_rows() if int(r["participant"]) <= participants]
    analysis = analyze(rows, measures=["accepted", "trust"])
    trust = analysis.measures["trust"]
    notes = " ".join(trust.notes)
    for phrase in warned:
        assert phrase in notes
    if not warned:
        assert "too few" not in notes
        assert "only 1" not in notes
    if participants == 1:
        assert trust.friedman.kendall_w == 1.0
        assert "Kendall's W is 1 (or undefined) whatever the answers" in render_text(analysis)
    if participants == 3:
        assert "the smallest possible exact p is 0.0278" in notes


def test_bad_rows_are_refused_readably() -> None:
    with pytest.raises(
        AnalysisError, match=r"row 1 \(participant 1, condition copy\), column trust: 'high'"
    ):
        analyze([{"participant": "1", "condition": "copy", "trust": "high"}])
    with pytest.raises(AnalysisError, match="has copy twice"):
        analyze([{"participant": "1", "condition": "copy", "trust": 1}] * 2)
    with pytest.raises(AnalysisError, match="no measure columns"):
        analyze([{"participant": "1", "condition": "copy"}])


def test_questionnaire_scores_reverse_keyed_items() -> None:
    credibility = load_default_study().questionnaire("credibility")
    reverse = {item.id for item in credibility.items if item.reverse}
    assert 0 < len(reverse) < 12
    # Always ticking the favourable end: 7 on normal items, 1 on reverse-keyed ones.
    favourable = {item.id: 1 if item.id in reverse else 7 for item in credibility.items}
    assert score_questionnaire(credibility, favourable) == 7.0
    all_fours = dict.fromkeys(favourable, 4)
    assert score_questionnaire(credibility, all_fours) == 4.0
    all_sevens = dict.fromkeys(favourable, 7)
    expected = (7 * (12 - len(reverse)) + 1 * len(reverse)) / 12
    assert score_questionnaire(credibility, all_sevens) == pytest.approx(expected)


def test_questionnaire_scoring_refuses_bad_answers() -> None:
    study = load_default_study()
    trust = study.questionnaire("trust")
    answers = {item.id: 5 for item in trust.items}
    with pytest.raises(ValueError, match="unanswered"):
        score_questionnaire(trust, dict(list(answers.items())[1:]))
    partial = dict(list(answers.items())[2:])
    assert score_questionnaire(trust, partial, allow_missing=True) == pytest.approx(
        sum(8 - 5 if i.reverse else 5 for i in trust.items[2:]) / 4
    )
    with pytest.raises(ValueError, match=r"outside 1\.\.7"):
        score_questionnaire(trust, {**answers, "moral": 8})
    with pytest.raises(ValueError, match="not numeric items"):
        score_questionnaire(trust, {**answers, "experience": 3})
    with pytest.raises(ValueError, match="no numeric items"):
        score_questionnaire(study.questionnaire("experience"), {})


def test_error_score_table() -> None:
    rows = [
        {"condition": "copy", "initial_error": 6, "final_error": 2},
        {"condition": "copy", "initial_error": 4, "final_error": 4},
        {"condition": "still", "initial_error": 8, "final_error": ""},
    ]
    table = error_score_table(rows)
    assert table["initial_error"]["copy"].mean == 5
    assert table["error_change"]["copy"].mean == -2
    assert table["error_change"]["still"].n == 0
    assert list(table["final_error"]) == ["copy", "still"]


def test_wilcoxon_on_tied_counts_uses_the_corrected_normal_approximation() -> None:
    """Hand-computed as R's wilcox.test does for ties: tie-corrected variance and a
    continuity correction, independent of SciPy."""
    from chameleons.experiment.stats.descriptive import wilcoxon_pair

    x = [3, 2, 2, 1, 3, 0, 2, 1, 3, 2, 1, 2]
    y = [1, 1, 2, 0, 1, 0, 1, 1, 2, 0, 0, 1]
    d = np.array(x) - np.array(y)
    d = d[d != 0]
    ranks = stats.rankdata(np.abs(d))
    n = len(d)
    t_plus = ranks[d > 0].sum()
    _, counts = np.unique(np.abs(d), return_counts=True)
    var = n * (n + 1) * (2 * n + 1) / 24 - (counts**3 - counts).sum() / 48
    shift = t_plus - n * (n + 1) / 4
    z = (shift - 0.5 * np.sign(shift)) / np.sqrt(var)
    expected = 2 * stats.norm.sf(abs(z))
    result = wilcoxon_pair("a", "b", x, y, pairs=3)
    assert result.p == pytest.approx(expected, rel=1e-9)
    assert result.p_bonferroni == pytest.approx(min(1.0, 3 * expected), rel=1e-9)
