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
    Zero differences are dropped (Wilcoxon's convention); all zero -> undefined."""
    if all(u == v for u, v in zip(x, y, strict=True)):
        return PairwiseTest(a, b, len(x), None, None, None, "all differences are zero")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = wilcoxon(x, y)
    note = "; ".join(str(w.message) for w in caught)
    p = float(result.pvalue)
    return PairwiseTest(a, b, len(x), float(result.statistic), p, bonferroni(p, pairs), note)
