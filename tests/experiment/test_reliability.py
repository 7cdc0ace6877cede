"""Cronbach's alpha and Feldt's interval against published examples and an independent
formula (Hoyt's ANOVA, which gives the same coefficient from other sums)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from chameleons.experiment.stats.reliability import (
    alpha_from_covariance,
    cronbach_alpha,
    feldt_interval,
)

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
