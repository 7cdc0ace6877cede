"""The Friedman test against published reference values and against SciPy."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest
from scipy import stats

from chameleons.experiment.stats import average_ranks, friedman, permutation_p
from chameleons.experiment.stats import friedman_test as friedman_module

# R's friedman.test example: Hollander & Wolfe (1973), p. 140 - times to round first base
# for 22 runners with three methods (round out, narrow angle, wide angle).
ROUNDING_TIMES = [
    [5.40, 5.50, 5.55], [5.85, 5.70, 5.75], [5.20, 5.60, 5.50], [5.55, 5.50, 5.40],
    [5.90, 5.85, 5.70], [5.45, 5.55, 5.60], [5.40, 5.40, 5.35], [5.45, 5.50, 5.35],
    [5.25, 5.15, 5.00], [5.85, 5.80, 5.70], [5.25, 5.20, 5.10], [5.65, 5.55, 5.45],
    [5.60, 5.35, 5.45], [5.05, 5.00, 4.95], [5.50, 5.50, 5.40], [5.45, 5.55, 5.50],
    [5.55, 5.55, 5.35], [5.45, 5.50, 5.55], [5.50, 5.45, 5.25], [5.65, 5.60, 5.40],
    [5.70, 5.65, 5.55], [6.30, 6.30, 6.25],
]  # fmt: skip

# SciPy's friedmanchisquare example: pulse before, immediately after and 5 min after exercise.
BEFORE = [72, 96, 88, 92, 74, 76, 82]
IMMEDIATELY_AFTER = [120, 120, 132, 120, 101, 96, 112]
FIVE_MIN_AFTER = [76, 95, 104, 96, 84, 72, 76]


def test_r_rounding_times_reference() -> None:
    result = friedman(ROUNDING_TIMES)
    assert result.n == 22
    assert result.df == 2
    assert result.chi2 is not None
    assert round(result.chi2, 3) == 11.143
    assert result.p == pytest.approx(0.003805, abs=5e-7)
    assert result.kendall_w == pytest.approx(result.chi2 / 44)


def test_scipy_documentation_reference() -> None:
    result = friedman(list(zip(BEFORE, IMMEDIATELY_AFTER, FIVE_MIN_AFTER, strict=True)))
    assert result.chi2 == pytest.approx(10.5714, abs=5e-5)
    assert result.p == pytest.approx(0.0050634, abs=5e-8)


@pytest.mark.parametrize("seed", range(6))
def test_matches_scipy_on_random_tied_integer_data(seed: int) -> None:
    rng = np.random.default_rng(seed)
    checked = 0
    for _ in range(60):
        n, k = int(rng.integers(2, 25)), int(rng.integers(3, 6))
        data = rng.integers(0, int(rng.integers(2, 8)), size=(n, k))
        if all(len(set(row)) == 1 for row in data):
            continue
        ours = friedman(data.tolist())
        reference = stats.friedmanchisquare(*data.T)
        assert ours.chi2 == pytest.approx(reference.statistic, rel=1e-9, abs=1e-12)
        assert ours.p == pytest.approx(reference.pvalue, rel=1e-9, abs=1e-15)
        checked += 1
    assert checked > 40


def test_all_tied_is_undefined_not_zero() -> None:
    result = friedman([[2, 2, 2], [1, 1, 1], [3, 3, 3]])
    assert result.chi2 is None
    assert result.p is None
    assert result.kendall_w is None
    assert friedman([]).chi2 is None
    assert permutation_p([[1, 1, 1]]).p is None


def test_tie_correction_matters_for_counts() -> None:
    accepted = [[1, 2, 2], [0, 1, 1], [3, 3, 2], [1, 1, 1], [2, 3, 3], [0, 1, 0]]
    corrected = friedman(accepted).chi2
    assert corrected == pytest.approx(stats.friedmanchisquare(*np.array(accepted).T).statistic)
    ranks = np.array([average_ranks(row) for row in accepted])
    n, k = ranks.shape
    uncorrected = 12 / (n * k * (k + 1)) * (ranks.sum(axis=0) ** 2).sum() - 3 * n * (k + 1)
    assert corrected is not None
    assert corrected > uncorrected * 1.3


def test_average_ranks() -> None:
    assert average_ranks([3, 1, 2]) == [3, 1, 2]
    assert average_ranks([5, 5, 1, 7]) == [2.5, 2.5, 1, 4]
    assert average_ranks([4, 4, 4]) == [2, 2, 2]


def test_perfect_agreement_has_kendall_w_one() -> None:
    assert friedman([[1, 2, 3]] * 5).kendall_w == pytest.approx(1.0)


def _scipy_permutation_p(data: list[list[int]]) -> float:
    """SciPy's exact within-block permutation test of the same statistic."""

    def statistic(*samples: np.ndarray, axis: int) -> Any:
        ranks = stats.rankdata(np.stack(samples, axis=-1), axis=-1)
        return (ranks.sum(axis=-2) ** 2).sum(axis=-1)

    columns = [np.array(c, dtype=float) for c in zip(*data, strict=True)]
    result = stats.permutation_test(
        columns, statistic, permutation_type="samples", n_resamples=np.inf,
        alternative="greater", vectorized=True,
    )  # fmt: skip
    return float(result.pvalue)


@pytest.mark.parametrize("seed", range(4))
def test_exact_permutation_p_matches_scipy_enumeration(seed: int) -> None:
    rng = np.random.default_rng(seed)
    data = rng.integers(0, 4, size=(5, 3)).tolist()
    if all(len(set(row)) == 1 for row in data):
        data[0] = [0, 1, 2]
    ours = permutation_p(data)
    assert ours.method == "exact"
    assert ours.p == pytest.approx(_scipy_permutation_p(data), rel=1e-9)


def test_exact_p_by_brute_force_enumeration() -> None:
    data = [[1, 2, 2], [0, 1, 3], [2, 2, 2], [3, 1, 0]]
    observed = stats.friedmanchisquare(*np.array(data).T).statistic
    at_least = total = 0
    for arrangement in itertools.product(*(itertools.permutations(row) for row in data)):
        total += 1
        chi2 = stats.friedmanchisquare(*np.array(arrangement).T).statistic
        at_least += chi2 >= observed - 1e-9
    assert permutation_p(data).p == pytest.approx(at_least / total)


def test_monte_carlo_is_seeded_and_close_to_exact(monkeypatch: pytest.MonkeyPatch) -> None:
    data = np.random.default_rng(3).integers(0, 4, size=(12, 3)).tolist()
    exact = permutation_p(data)
    monkeypatch.setattr(friedman_module, "MAX_EXACT_WORK", 1)
    sampled = permutation_p(data, resamples=20_000, seed=9)
    assert sampled.method == "monte-carlo"
    assert (sampled.resamples, sampled.seed) == (20_000, 9)
    assert sampled == permutation_p(data, resamples=20_000, seed=9)
    assert exact.p is not None
    assert sampled.p == pytest.approx(exact.p, abs=0.015)


# The textbook table of exact critical values of Friedman's statistic (the smallest value
# whose upper tail probability is at most alpha), k = 3 and k = 4 conditions, in the copy
# at https://fr.scribd.com/document/464088360/Tabla-de-Friedman-pdf.
CRITICAL_K3 = {  # n: (5 %, 1 %)
    3: (6.000, None), 4: (6.500, 8.000), 5: (6.400, 8.400), 6: (7.000, 9.000),
    7: (7.143, 8.857), 8: (6.250, 9.000), 9: (6.222, 9.556), 10: (6.200, 9.600),
    11: (6.545, 9.455), 12: (6.500, 9.500), 13: (6.615, 9.385), 14: (6.143, 9.143),
    15: (6.400, 8.933),
}  # fmt: skip
CRITICAL_K4 = {2: (6.000, None), 3: (7.400, 9.000), 4: (7.800, 9.600), 5: (7.800, 9.960),
               6: (7.600, 10.200)}  # fmt: skip


def exact_critical_value(n: int, k: int, alpha: float) -> float | None:
    """The smallest attainable chi2 whose exact upper tail is <= alpha, from the module's
    exact distribution (untied blocks)."""
    doubled = [tuple(range(2, 2 * k + 1, 2))] * n
    lowest = 4 * k * (n * (k + 1) // 2) ** 2 if n * (k + 1) % 2 == 0 else k * (n * (k + 1)) ** 2
    highest = 4 * sum((n * r) ** 2 for r in range(1, k + 1))
    values = list(range(lowest - lowest % 4, highest + 1, 4))
    tails = [float(friedman_module._exact_p(doubled, s) or 0.0) for s in values]
    for index, s in enumerate(values):
        attained = index + 1 == len(values) or tails[index] - tails[index + 1] > 1e-15
        if attained and tails[index] <= alpha + 1e-12:
            return 12 / (n * k * (k + 1)) * s / 4 - 3 * n * (k + 1)
    return None


@pytest.mark.parametrize(("k", "table"), [(3, CRITICAL_K3), (4, CRITICAL_K4)])
def test_exact_distribution_reproduces_the_published_critical_values(k, table) -> None:
    for n, (five, one) in table.items():
        for alpha, expected in ((0.05, five), (0.01, one)):
            found = exact_critical_value(n, k, alpha)
            if expected is None:
                assert found is None, (n, alpha)
            else:
                assert found is not None, (n, alpha)
                assert round(found, 3) == expected, (n, alpha, found)
