"""Power simulation against closed forms (the sign-test form of the two-condition Friedman
test; the noncentral F of the balanced mixed model), statsmodels, and its own Monte Carlo
error."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from chameleons.experiment.stats.models import fit_models
from chameleons.experiment.stats.power import (
    Assumptions,
    Design,
    PowerError,
    Settings,
    balanced_lmm_wald,
    default_sample_sizes,
    planned_design,
    simulate,
    simulate_scores,
)
from chameleons.experiment.study import load_default_study

WIDE = (-100.0, 100.0)  # a scale nothing is clipped to


def crossover(n: int) -> Design:
    """Two conditions, half the participants AB, half BA (a 2x2 crossover)."""
    positions = np.array([[1, 2] if i % 2 == 0 else [2, 1] for i in range(n)])
    item_sets = np.array([["better", "worse"]] * n)
    return Design(("a", "b"), positions, item_sets, 3)


def test_two_condition_friedman_power_equals_the_binomial_closed_form() -> None:
    """With two conditions the Friedman statistic is (2B - n)^2 / n, B ~ Binomial(n, q),
    q = P(x_a > x_b) = Phi(delta / (sd_within sqrt 2)): its power is a finite sum."""
    n, delta, sd = 20, 0.5, 1.0
    assumptions = Assumptions(
        acceptance={"a": 0.5, "b": 0.5},
        scores={"a": delta, "b": 0.0},
        score_sd_between=0.8,
        score_sd_within=sd,
        scale=WIDE,
    )
    settings = Settings(sample_sizes=(n,), replicates=20_000, model_replicates=0, tests=1)
    row = simulate({n: crossover(n)}, assumptions, settings).rows[0]
    q = stats.norm.cdf(delta / (sd * math.sqrt(2)))
    critical = stats.chi2.ppf(0.95, 1)
    b = np.arange(n + 1)
    exact = float(stats.binom.pmf(b, n, q)[(2 * b - n) ** 2 / n > critical].sum())
    simulated = row["score_friedman"]
    assert simulated["se"] == pytest.approx(math.sqrt(exact * (1 - exact) / 20_000), rel=0.05)
    assert abs(simulated["power"] - exact) < 4 * simulated["se"]


def test_score_model_power_equals_the_noncentral_f_closed_form() -> None:
    """Complete balanced data from the paper's plan (24 participants): the score model's
    F test has power P(F'(k-1, df, lambda) > F_crit), lambda = n sum (mu - mean)^2 / s^2."""
    study = load_default_study()
    n = 24
    means = {"still": 4.5, "natural": 4.6, "copy": 5.0}
    sd = 0.8
    assumptions = Assumptions(
        acceptance=dict.fromkeys(means, 0.5),
        scores=means,
        score_sd_between=2.0,  # far from the boundary: REML keeps the within variance
        score_sd_within=sd,
        scale=WIDE,
    )
    settings = Settings(sample_sizes=(n,), replicates=20_000, model_replicates=0, tests=4)
    row = simulate({n: planned_design(study, n)}, assumptions, settings, "still").rows[0]
    k = 3
    mu = np.array(list(means.values()))
    noncentrality = n * ((mu - mu.mean()) ** 2).sum() / sd**2
    df_within = n * (k - 1) - 2 * (k - 1)
    critical = stats.f.ppf(1 - 0.05 / 4, k - 1, df_within)
    exact = float(stats.ncf.sf(critical, k - 1, df_within, noncentrality))
    assert abs(row["score_model"]["power"] - exact) < 4 * row["score_model"]["se"]


@pytest.mark.parametrize("sd_between", [0.0, 0.3, 1.5])
def test_closed_form_wald_equals_statsmodels_mixed_model(sd_between: float) -> None:
    """Including data where the participant variance estimate sits at its boundary 0."""
    study = load_default_study()
    design = planned_design(study, 12)
    assumptions = Assumptions(
        acceptance={"still": 0.5, "natural": 0.5, "copy": 0.5},
        scores={"still": 4.0, "natural": 4.3, "copy": 4.8},
        score_sd_between=sd_between,
        score_sd_within=0.7,
        scale=WIDE,
    )
    scores = simulate_scores(design, assumptions, 4, np.random.default_rng(3))
    ours = balanced_lmm_wald(scores, design, "still")
    for r in range(4):
        rows = [
            {
                "participant": f"P{i}",
                "condition": condition,
                "position": int(design.positions[i, j]),
                "trust": float(scores[r, i, j]),
            }
            for i in range(12)
            for j, condition in enumerate(design.conditions)
        ]
        model = fit_models(
            rows, None, measures=["trust"], conditions=list(design.conditions), reference="still"
        ).scores["trust"]
        test = model.test("condition")
        assert test is not None
        assert ours[r] == pytest.approx(test.chi2, rel=2e-3)


def exact_friedman_size(n: int, k: int, alpha: float) -> float:
    """P(chi2 > critical) under the null for untied data: the exact distribution of the
    rank sums, convolved block by block (every order of 1..k equally likely)."""
    from itertools import permutations

    states: dict[tuple[int, ...], float] = {(0,) * k: 1.0}
    orders = list(permutations(range(1, k + 1)))
    for _ in range(n):
        following: dict[tuple[int, ...], float] = {}
        for sums, probability in states.items():
            for order in orders:
                key = tuple(a + b for a, b in zip(sums, order, strict=True))
                following[key] = following.get(key, 0.0) + probability / len(orders)
        states = following
    critical = stats.chi2.ppf(1 - alpha, k - 1)
    return sum(
        probability
        for sums, probability in states.items()
        if 12 / (n * k * (k + 1)) * sum(r * r for r in sums) - 3 * n * (k + 1) > critical + 1e-9
    )


def test_null_rejection_rates_and_monte_carlo_error() -> None:
    """Under no effect: the untied Friedman test rejects as often as its exact null
    distribution says (the chi-squared approximation is a little liberal at n = 12), the
    score model's F test at its level, and two seeds agree within their Monte Carlo error."""
    study = load_default_study()
    designs = {12: planned_design(study, 12), 24: planned_design(study, 24)}
    null = Assumptions(
        acceptance=dict.fromkeys(study.condition_ids, 0.5),
        scores=dict.fromkeys(study.condition_ids, 4.0),
        scale=WIDE,  # untied, unclipped scores
    )
    first, second = (
        simulate(designs, null, Settings((12, 24), 6000, 40, tests=1, seed=s), "still")
        for s in (1, 2)
    )
    for row_a, row_b in zip(first.rows, second.rows, strict=True):
        exact = exact_friedman_size(row_a["n"], 3, 0.05)
        friedman = row_a["score_friedman"]
        assert abs(friedman["power"] - exact) < 4 * friedman["se"]
        model = row_a["score_model"]
        assert abs(model["power"] - 0.05) < 4 * model["se"]
        assert row_a["accepted_friedman"]["power"] < 0.05 + 4 * row_a["accepted_friedman"]["se"]
        for test in ("accepted_friedman", "score_friedman", "score_model"):
            a, b = row_a[test], row_b[test]
            assert abs(a["power"] - b["power"]) < 4 * math.hypot(a["se"], b["se"])
        assert row_a["accepted_model"]["replicates"] == 40
    assert exact_friedman_size(12, 3, 0.05) > 0.05  # why the chi-squared test runs liberal
    again = simulate(designs, null, Settings((12, 24), 6000, 40, tests=1, seed=1), "still")
    assert again.rows == first.rows  # same seed, same numbers


def test_the_paper_design_needs_more_participants_for_a_real_effect() -> None:
    study = load_default_study()
    sizes = default_sample_sizes(study, 5)
    assert sizes == (12, 24, 36, 48, 60)
    design = planned_design(study, 12)
    for j in range(3):  # each condition in each position 4 times (Williams design)
        assert sorted(np.bincount(design.positions[:, j])[1:].tolist()) == [4, 4, 4]
    effect = Assumptions(
        acceptance={"still": 0.45, "natural": 0.45, "copy": 0.7},
        scores={"still": 4.7, "natural": 4.7, "copy": 5.4},
    )
    designs = {n: planned_design(study, n) for n in sizes}
    result = simulate(designs, effect, Settings(sizes, 2000, 20, seed=5), "still")
    powers = [row["score_model"]["power"] for row in result.rows]
    assert powers == sorted(powers)  # more participants, more power (a clear trend)
    needed = result.needed["score_model"]
    assert needed is not None
    assert needed == min(r["n"] for r in result.rows if r["score_model"]["power"] >= 0.8)
    assert result.to_dict()["design"]["conditions"] == ["still", "natural", "copy"]


def test_bad_assumptions_are_refused_readably() -> None:
    study = load_default_study()
    designs = {12: planned_design(study, 12)}
    good = dict.fromkeys(study.condition_ids, 0.5)
    scores = dict.fromkeys(study.condition_ids, 4.0)
    with pytest.raises(PowerError, match="no value for condition"):
        simulate(designs, Assumptions({"still": 0.5}, scores), Settings((12,)))
    with pytest.raises(PowerError, match="between 0 and 1"):
        simulate(designs, Assumptions({**good, "copy": 1.0}, scores), Settings((12,)))
    with pytest.raises(PowerError, match="on the scale"):
        simulate(designs, Assumptions(good, {**scores, "copy": 9.0}), Settings((12,)))
