"""Two to six conditions through the analysis: Friedman with k - 1 df, all k(k-1)/2
post-hoc pairs with Bonferroni over the pairs, Table I and the LaTeX table with a row per
condition, and a plot per measure."""

from __future__ import annotations

import math
from itertools import combinations

import pytest

from chameleons.backend.analysis.plots import plot_measure
from chameleons.experiment.stats import analyze, render_latex
from chameleons.experiment.stats.wilcoxon import signed_rank_test


@pytest.mark.parametrize("k", [2, 3, 4, 5, 6])
def test_k_conditions_give_every_pair_with_bonferroni_over_the_pairs(k: int) -> None:
    conditions = [f"c{j}" for j in range(k)]
    # A strong, consistent effect: condition j is j points better for everyone.
    values = {(p, c): 1 + j + (p % 3) / 10 for p in range(12) for j, c in enumerate(conditions)}
    rows = [
        {"participant": f"P{p:02d}", "condition": c, "trust": value}
        for (p, c), value in values.items()
    ]
    analysis = analyze(rows, measures=["trust"], conditions=conditions, condition_order=conditions)
    result = analysis.measures["trust"]
    assert (result.friedman.k, result.friedman.df) == (k, k - 1)
    pairs = list(combinations(conditions, 2))
    assert [(t.a, t.b) for t in result.posthoc] == pairs
    assert len(pairs) == math.comb(k, 2)
    for test in result.posthoc:
        a = [values[(p, test.a)] for p in range(12)]
        b = [values[(p, test.b)] for p in range(12)]
        raw = signed_rank_test(a, b).p
        assert raw is not None
        assert test.p == pytest.approx(raw)
        assert test.p_bonferroni == pytest.approx(min(1.0, raw * len(pairs)))
    labels = {c: f"Condition {c.upper()}" for c in conditions}
    latex = render_latex(analysis, labels)
    assert all(latex.count(label) == 1 for label in labels.values())
    assert rf"\multirow{{{k}}}*" in latex
    image = plot_measure(
        list(result.values.values()), "trust", conditions, labels, (1, 7), fmt="svg"
    )
    assert all(label.encode() in image for label in labels.values())
