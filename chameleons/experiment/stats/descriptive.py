"""Descriptive statistics and post-hoc pairwise tests."""

from __future__ import annotations

import statistics
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

from scipy.stats import wilcoxon


@dataclass(frozen=True)
class Descriptive:
    n: int
    median: float | None
    mean: float | None
    sd: float | None  # sample SD (ddof = 1); None below 2 values


def describe(values: Sequence[float]) -> Descriptive:
    if not values:
        return Descriptive(0, None, None, None)
    sd = statistics.stdev(values) if len(values) > 1 else None
    return Descriptive(len(values), statistics.median(values), statistics.fmean(values), sd)


@dataclass(frozen=True)
class PairwiseTest:
    a: str
    b: str
    n: int
    statistic: float | None  # Wilcoxon W (smaller signed-rank sum); None: undefined
    p: float | None
    p_bonferroni: float | None
    note: str = ""


def bonferroni(p: float | None, tests: int) -> float | None:
    return None if p is None else min(1.0, p * tests)


def wilcoxon_pair(
    a: str, b: str, x: Sequence[float], y: Sequence[float], pairs: int
) -> PairwiseTest:
    """Wilcoxon signed-rank test of paired values (SciPy), Bonferroni over ``pairs`` tests.
    Zero differences are dropped (Wilcoxon's convention); all zero -> undefined.

    The p-value follows R's ``wilcox.test``: exact for fewer than 50 non-zero differences
    without ties, otherwise the normal approximation with tie and continuity correction.
    (SciPy's default would fall back to a slow permutation test on tied data.)"""
    differences = [u - v for u, v in zip(x, y, strict=True) if u != v]
    if not differences:
        return PairwiseTest(a, b, len(x), None, None, None, "all differences are zero")
    magnitudes = [abs(d) for d in differences]
    exact = len(differences) < 50 and len(set(magnitudes)) == len(magnitudes)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = wilcoxon(x, y, method="exact" if exact else "approx", correction=not exact)
    note = "; ".join(str(w.message) for w in caught)
    p = float(result.pvalue)
    return PairwiseTest(a, b, len(x), float(result.statistic), p, bonferroni(p, pairs), note)
