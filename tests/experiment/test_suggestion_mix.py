"""The suggestion mix per condition in the analysis (text, JSON), counted independently."""

from __future__ import annotations

import json
from collections import Counter

import numpy as np
import pytest
from scipy import stats

from chameleons.experiment.stats import analyze, render_text
from tests.experiment.test_models import CONDITIONS, simulated


def test_the_analysis_reports_the_mix_per_condition_and_tests_it_per_participant() -> None:
    scores, suggestions = simulated(n=12, seed=3)
    for row in suggestions:  # copy's suggestions go random more often, as in a rehearsal
        if row["condition"] == "copy" and row["index"] != 1:
            row["kind"] = "random"
        row["direction"] = "down" if row["index"] == 2 and row["kind"] == "optimal" else "up"
    analysis = analyze(scores, measures=["accepted", "trust"], suggestions=suggestions)
    mix = analysis.suggestion_mix
    assert mix is not None
    kinds = Counter((r["condition"], r["kind"]) for r in suggestions)
    downs = Counter(r["condition"] for r in suggestions if r["direction"] == "down")
    assert [(c.condition, c.optimal, c.random, c.down) for c in mix.conditions] == [
        (c, kinds[(c, "optimal")], kinds[(c, "random")], downs[c]) for c in CONDITIONS
    ]
    per = Counter((r["participant"], r["condition"]) for r in suggestions if r["kind"] == "random")
    participants = sorted({r["participant"] for r in suggestions})
    counts = np.array([[per[(p, c)] for c in CONDITIONS] for p in participants], dtype=float)
    reference = stats.friedmanchisquare(*counts.T)
    assert mix.friedman.chi2 == pytest.approx(reference.statistic)
    assert mix.friedman.p == pytest.approx(reference.pvalue)
    assert mix.permutation is not None
    assert mix.permutation.method == "exact"
    text = render_text(analysis)
    copy = next(c for c in mix.conditions if c.condition == "copy")
    assert f"Copy                   {copy.total} suggestions: {copy.optimal} optimal" in text
    assert "random suggestions per participant and condition: Friedman chi2(2) = " in text
    data = json.loads(json.dumps(analysis.to_dict()))
    assert data["suggestion_mix"]["conditions"][1]["random_share"] == copy.random / copy.total


def test_no_suggestion_rows_no_mix() -> None:
    scores, _ = simulated(n=6)
    assert analyze(scores, measures=["accepted"]).suggestion_mix is None
