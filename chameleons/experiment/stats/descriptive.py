"""Descriptive statistics (exact, see :mod:`.rounding`) and post-hoc pairwise tests."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from decimal import Decimal
from fractions import Fraction
from typing import Any

from chameleons.experiment.stats.rounding import exact, fmt, sqrt
from chameleons.experiment.stats.wilcoxon import DEFAULT_RULE, WilcoxonRule, signed_rank_test


@dataclass(frozen=True)
class Descriptive:
    n: int
    median: float | None
    mean: float | None
    sd: float | None  # sample SD (ddof = 1); None below 2 values
    # The exact values the floats come from; every displayed number is rounded from these.
    exact_median: Fraction | None = field(default=None, compare=False, repr=False)
    exact_mean: Fraction | None = field(default=None, compare=False, repr=False)
    exact_sd: Decimal | None = field(default=None, compare=False, repr=False)

    def to_dict(self) -> dict[str, Any]:
        return {"n": self.n, "median": self.median, "mean": self.mean, "sd": self.sd}

    def cell(self, digits: int = 1, plus_minus: str = "±", missing: str = "no data") -> str:
        """``median, mean ± SD`` as Table I shows it."""
        if self.n == 0:
            return missing
        return (
            f"{fmt(self.exact_median, digits)}, {fmt(self.exact_mean, digits)} {plus_minus} "
            f"{fmt(self.exact_sd, digits, '--')}"
        )


def describe(values: Sequence[float]) -> Descriptive:
    if not values:
        return Descriptive(0, None, None, None)
    exact_values = sorted(exact(v) for v in values)
    n = len(exact_values)
    middle = n // 2
    median = (
        exact_values[middle] if n % 2 else (exact_values[middle - 1] + exact_values[middle]) / 2
    )
    mean = sum(exact_values, Fraction(0)) / n
    sd = None
    if n > 1:
        sd = sqrt(sum(((v - mean) ** 2 for v in exact_values), Fraction(0)) / (n - 1))
    return Descriptive(
        n,
        float(median),
        float(mean),
        None if sd is None else float(sd),
        exact_median=median,
        exact_mean=mean,
        exact_sd=sd,
    )


@dataclass(frozen=True)
class PairwiseTest:
    a: str
    b: str
    n: int  # pairs compared
    statistic: float | None  # W: the smaller signed-rank sum; None: undefined
    p: float | None
    p_bonferroni: float | None
    note: str = ""
    v: float | None = None  # R's V: rank sum of the positive differences a - b
    method: str = ""
    nonzero: int = 0  # pairs with a non-zero difference (the test's n)

    def to_dict(self) -> dict[str, Any]:
        return {
            "a": self.a,
            "b": self.b,
            "n": self.n,
            "n_nonzero": self.nonzero,
            "statistic": self.statistic,
            "v": self.v,
            "p": self.p,
            "p_bonferroni": self.p_bonferroni,
            "method": self.method,
            "note": self.note,
        }


def bonferroni(p: float | None, tests: int) -> float | None:
    return None if p is None else min(1.0, p * tests)


def wilcoxon_pair(
    a: str,
    b: str,
    x: Sequence[float],
    y: Sequence[float],
    pairs: int,
    rule: WilcoxonRule = DEFAULT_RULE,
) -> PairwiseTest:
    """Wilcoxon signed-rank test of paired values exactly as R's ``wilcox.test(x, y,
    paired = TRUE)`` (see :mod:`.wilcoxon`), Bonferroni over ``pairs`` tests. Every
    difference zero: undefined (R gives NaN)."""
    result = signed_rank_test(x, y, rule)
    if result.p is None:
        return PairwiseTest(a, b, len(x), None, None, None, "all differences are zero", None, "")
    notes = []
    if result.zeros:
        notes.append(f"{result.zeros} zero difference(s) dropped")
    if result.ties:
        notes.append("tied differences")
    return PairwiseTest(
        a,
        b,
        len(x),
        result.w,
        result.p,
        bonferroni(result.p, pairs),
        "; ".join(notes),
        result.v,
        result.method,
        result.n,
    )
