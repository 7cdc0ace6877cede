"""Cronbach's alpha and Feldt's interval against published examples and an independent
formula (Hoyt's ANOVA, which gives the same coefficient from other sums)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from chameleons.experiment.model import Questionnaire
from chameleons.experiment.stats.reliability import (
    alpha_from_covariance,
    cluster_bootstrap_interval,
    cronbach_alpha,
    feldt_interval,
)
from chameleons.experiment.stats.scale_reliability import scale_reliability
from chameleons.experiment.study import load_default_study

# Statology's "How to Calculate Cronbach's Alpha in Python" (2021): pingouin's
# cronbach_alpha gives (0.7734375, array([0.336, 0.939])) for these ten answers.
Q1 = [1, 2, 2, 3, 2, 2, 3, 3, 2, 3]
Q2 = [1, 1, 1, 2, 3, 3, 2, 3, 3, 3]
Q3 = [1, 1, 2, 1, 2, 3, 3, 3, 2, 3]


def test_reproduces_pingouins_published_example() -> None:
    result = cronbach_alpha("survey", ["q1", "q2", "q3"], list(zip(Q1, Q2, Q3, strict=True)))
    assert result.alpha == pytest.approx(0.7734375, abs=1e-12)
    assert (round(result.ci_low or 0, 3), round(result.ci_high or 0, 3)) == (0.336, 0.939)
    assert (result.n, result.items) == (10, 3)


def test_reproduces_statsbase_documented_covariance_example() -> None:
    """Julia StatsBase's cronbachalpha docstring: 0.8136 for all items, and 0.7500,
    0.7606, 0.7714, 0.7826 with items 1-4 dropped."""
    covariance = np.array([[10, 6, 6, 6], [6, 11, 6, 6], [6, 6, 12, 6], [6, 6, 6, 13]])
    assert round(alpha_from_covariance(covariance) or 0, 4) == 0.8136
    dropped = [
        round(alpha_from_covariance(np.delete(np.delete(covariance, i, 0), i, 1)) or 0, 4)
        for i in range(4)
    ]
    assert dropped == [0.75, 0.7606, 0.7714, 0.7826]


def hoyt_alpha(data: np.ndarray) -> float:
    """Hoyt (1941): alpha = 1 - MS(residual) / MS(persons) of the persons x items ANOVA."""
    n, k = data.shape
    grand = data.mean()
    ss_persons = k * ((data.mean(axis=1) - grand) ** 2).sum()
    ss_items = n * ((data.mean(axis=0) - grand) ** 2).sum()
    ss_residual = ((data - grand) ** 2).sum() - ss_persons - ss_items
    ms_persons = ss_persons / (n - 1)
    ms_residual = ss_residual / ((n - 1) * (k - 1))
    return float(1 - ms_residual / ms_persons)


@settings(max_examples=60)
@example(cases=[[1, 3, 3], [1, 5, 1], [1, 5, 1]])  # a constant sum score, off zero by rounding
@given(
    st.integers(3, 30).flatmap(
        lambda n: st.integers(2, 8).flatmap(
            lambda k: st.lists(
                st.lists(st.integers(1, 7), min_size=k, max_size=k), min_size=n, max_size=n
            )
        )
    )
)
def test_agrees_with_hoyts_anova_formula(cases: list[list[int]]) -> None:
    data = np.asarray(cases, dtype=float)
    result = cronbach_alpha("s", [f"i{j}" for j in range(data.shape[1])], cases)
    if data.sum(axis=1).var() == 0:
        assert result.alpha is None
        return
    alpha, low, high = result.alpha, result.ci_low, result.ci_high
    assert alpha == pytest.approx(hoyt_alpha(data), abs=1e-9)
    assert alpha is not None
    assert low is not None
    assert high is not None
    assert low <= alpha <= high


def test_feldt_interval_is_cocrons_formula() -> None:
    """cocron's cronbach.alpha.CI (Feldt, Woodruff & Salih 1987, formulas 6-7), written out
    with the F quantiles it names."""
    from scipy.stats import f

    low, high = feldt_interval(0.83, 100, 20)
    assert low == pytest.approx(1 - 0.17 * f.ppf(0.975, 99, 99 * 19))
    assert high == pytest.approx(1 - 0.17 * f.ppf(0.025, 99, 99 * 19))
    assert low is not None
    assert high is not None
    assert low < 0.83 < high


def test_undefined_cases_say_why() -> None:
    assert cronbach_alpha("s", ["a"], [[1], [2]]).note == "needs two items or more"
    assert cronbach_alpha("s", ["a", "b"], [[1, 2]]).note == "needs two complete cases or more"
    flat = cronbach_alpha("s", ["a", "b"], [[3, 3], [3, 3], [3, 3]])
    assert flat.alpha is None
    assert "does not vary" in flat.note


def correlated_cases(participants: int, items: int, seed: int) -> list[list[float]]:
    rng = np.random.default_rng(seed)
    trait = rng.normal(0, 1, participants)
    return [list(np.clip(np.round(4 + t + rng.normal(0, 0.9, items)), 1, 7)) for t in trait]


def test_repeated_ratings_do_not_narrow_the_pooled_interval() -> None:
    """A participant who rates three robots identically adds no information. Feldt's
    interval treats the three copies as independent cases and narrows; the interval that
    resamples participants is exactly the one of their single ratings (alpha does not
    change when every case is repeated, and the draws of participants are the same)."""
    single = correlated_cases(12, 6, seed=1)
    tripled = [case for case in single for _ in range(3)]
    who = [f"P{i}" for i in range(12) for _ in range(3)]
    once = cronbach_alpha("s", list("abcdef"), single)
    thrice = cronbach_alpha("s", list("abcdef"), tripled)
    assert thrice.alpha == pytest.approx(once.alpha, abs=1e-12)
    feldt_once = (once.ci_high or 0) - (once.ci_low or 0)
    feldt_thrice = (thrice.ci_high or 0) - (thrice.ci_low or 0)
    assert feldt_thrice < 0.6 * feldt_once  # Feldt: as if there were 36 people
    low, high, _ = cluster_bootstrap_interval(tripled, who, seed=3, key="s")
    low1, high1, _ = cluster_bootstrap_interval(single, [f"P{i}" for i in range(12)], seed=3,
                                                key="s")  # fmt: skip
    assert (low, high) == pytest.approx((low1, high1), abs=1e-12)
    assert low is not None
    assert high is not None
    assert low < (once.alpha or 0) < high


def test_cluster_interval_equals_a_slow_bootstrap_of_cronbach_alpha() -> None:
    """The interval's per-participant sums give, resample by resample, the alpha of the
    resampled cases themselves: a slow loop that builds each resample and calls
    cronbach_alpha (the same draws of participants) gives the same interval."""
    import zlib

    cases = correlated_cases(30, 5, seed=4)
    who = [f"P{i % 11}" for i in range(30)]  # 11 participants with 2 or 3 ratings each
    low, high, note = cluster_bootstrap_interval(cases, who, resamples=400, seed=7, key="k")
    names = sorted(set(who))
    rng = np.random.default_rng([7, zlib.crc32(b"alpha:k")])
    draws = rng.integers(0, len(names), size=(400, len(names)))
    slow = []
    for draw in draws:
        chosen = [case for j in draw for case, w in zip(cases, who, strict=True)
                  if w == names[j]]  # fmt: skip
        alpha = cronbach_alpha("s", list("abcde"), chosen).alpha
        if alpha is not None:
            slow.append(alpha)
    assert (low, high) == pytest.approx(tuple(np.quantile(slow, [0.025, 0.975])), abs=1e-9)
    assert len(slow) == 400
    assert note == ""


def test_alpha_per_condition_uses_one_rating_per_participant_with_feldt() -> None:
    study = load_default_study()
    trust: Questionnaire = study.questionnaire("trust")
    items = trust.numeric_items
    conditions = ["natural", "copy", "still"]
    cases = {c: correlated_cases(10, len(items), seed=n) for n, c in enumerate(conditions)}
    rows = [
        {"participant": f"P{p}", "session": p, "position": position, "condition": "x",
         "questionnaire": "trust", "item": item.id, "scored_value": value}
        for position, c in enumerate(conditions, start=1)
        for p, case in enumerate(cases[c])
        for item, value in zip(items, case, strict=True)
    ]  # fmt: skip
    # The view's conditions come from the scores (the answer row's own column says "x").
    view = {(f"P{p}", str(pos)): c for pos, c in enumerate(conditions, 1) for p in range(10)}
    order = ["still", "copy", "natural"]
    results = scale_reliability(study.questionnaires, rows, conditions=view, condition_order=order)
    result = next(r for r in results if r.scale == "trust")
    assert result.participants == 10
    assert result.n == 30
    assert [c.condition for c in result.by_condition] == ["still", "copy", "natural"]
    for per in result.by_condition:
        expected = cronbach_alpha("trust", [i.id for i in items], cases[per.condition])
        assert (per.alpha, per.ci_low, per.ci_high, per.n) == (
            expected.alpha, expected.ci_low, expected.ci_high, 10,
        )  # fmt: skip
        assert per.method == "Feldt"
