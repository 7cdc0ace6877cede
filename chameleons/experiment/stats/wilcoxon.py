"""The paired Wilcoxon signed-rank test exactly as R's ``wilcox.test(x, y, paired = TRUE)``
computes it (two-sided, ``mu = 0``, ``correct = TRUE``, ``exact = NULL``, ``digits.rank = Inf``).

Read from R's source, ``src/library/stats/R/wilcox.test.R`` (R 4.5: the one-sample branch of
``wilcox.test.default``; R 4.6: ``.wilcox_test_one_stat_*``, ``.wilcox_test_one_pval_*`` and
``.psignrank``):

- ``d = x - y``; zero differences are dropped (Wilcoxon's convention); ``n`` is the number
  left. The magnitudes ``|d|`` are ranked, tied magnitudes sharing their mean rank (compared
  as the exact doubles R would see).
- ``V`` is the sum of the ranks of the positive differences (R's statistic ``V``).
- **Exact** p when ``n < 50`` and there are no zeros (R < 4.6: and no ties). Two-sided:
  ``p = P(V* <= V)`` when ``V <= n(n+1)/4``, else ``p = 1 - P(V* <= V - 1)``, then
  ``min(2p, 1)``. ``V*`` is the null distribution of the statistic: every sign pattern of the
  ranks equally likely; with ties (R >= 4.6) it is the conditional distribution over the
  observed (mid-)ranks, which is what R's ``cpermdist1`` (the Streitberg-Roehmel shift
  algorithm) computes.
- Otherwise the **normal approximation with continuity correction**:
  ``z = (V - n(n+1)/4 - sign(.) / 2) / sigma`` with
  ``sigma^2 = n(n+1)(2n+1)/24 - sum(t^3 - t)/48`` over groups of ``t`` tied ranks, and
  ``p = 2 min(Phi(z), 1 - Phi(z))``.
- ``n = 0`` (every difference zero): R's p is ``NaN``; here it is undefined (``None``).

``rule`` chooses between the two R versions, which differ only for tied magnitudes without
zeros: ``"R<4.6"`` (R 4.5 and earlier: normal approximation whenever ties or zeros exist)
and ``"R>=4.6"`` (exact conditional p-value with ties, when there are no zeros).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.special import ndtr

from chameleons.experiment.stats.friedman_test import average_ranks

WilcoxonRule = Literal["R<4.6", "R>=4.6"]
WILCOXON_RULES: tuple[WilcoxonRule, ...] = ("R<4.6", "R>=4.6")
DEFAULT_RULE: WilcoxonRule = "R<4.6"
EXACT_BELOW = 50  # R: exact <- (n < 50)
EXACT = "exact"
EXACT_CONDITIONAL = "exact (conditional on ties)"
NORMAL = "normal approximation with continuity correction"
_SQRT_EPS = math.sqrt(np.finfo(float).eps)  # R: s < e + sqrt(.Machine$double.eps)


@dataclass(frozen=True)
class SignedRankResult:
    pairs: int  # pairs compared
    n: int  # non-zero differences (the test's n)
    zeros: int
    ties: bool  # tied magnitudes among the non-zero differences
    v: float  # R's V: rank sum of the positive differences x - y
    w: float  # min(V, n(n+1)/2 - V): the smaller signed-rank sum (SciPy's statistic)
    p: float | None  # two-sided; None when every difference is zero
    method: str  # EXACT, EXACT_CONDITIONAL or NORMAL ("" when undefined)


def signed_rank_test(
    x: Sequence[float], y: Sequence[float], rule: WilcoxonRule = DEFAULT_RULE
) -> SignedRankResult:
    """Two-sided paired Wilcoxon signed-rank test of ``x`` against ``y``, as R does it."""
    if len(x) != len(y):
        raise ValueError("x and y must have the same length")
    if rule not in WILCOXON_RULES:
        raise ValueError(f"unknown rule {rule!r}; use one of {', '.join(WILCOXON_RULES)}")
    differences = [float(a) - float(b) for a, b in zip(x, y, strict=True)]
    nonzero = [d for d in differences if d != 0]
    zeros, n = len(differences) - len(nonzero), len(nonzero)
    ranks = average_ranks([abs(d) for d in nonzero])
    v = sum(r for r, d in zip(ranks, nonzero, strict=True) if d > 0)
    ties = len(set(ranks)) != len(ranks)
    w = min(v, n * (n + 1) / 2 - v)
    if n == 0:
        return SignedRankResult(len(differences), 0, zeros, False, 0.0, 0.0, None, "")
    exact = n < EXACT_BELOW and zeros == 0 and (rule == "R>=4.6" or not ties)
    if exact:
        p = _exact_p(v, ranks)
        method = EXACT_CONDITIONAL if ties else EXACT
    else:
        p, method = _normal_p(v, ranks), NORMAL
    return SignedRankResult(len(differences), n, zeros, ties, v, w, p, method)


def null_distribution(ranks: Sequence[float]) -> tuple[np.ndarray, int]:
    """Probabilities of ``f * V*`` = 0, 1, 2, ... under the null (each rank's sign +/- with
    probability 1/2), and the scale ``f`` (2 when there are mid-ranks ``x.5``, else 1)."""
    scale = 1 if all(float(r).is_integer() for r in ranks) else 2
    scores = [round(scale * r) for r in ranks]
    density = np.zeros(sum(scores) + 1)
    density[0] = 1.0
    for score in scores:
        shifted = np.zeros_like(density)
        shifted[score:] = density[: density.size - score]
        density = 0.5 * (density + shifted)
    return density, scale


def _lower_tail(q: float, density: np.ndarray, scale: int) -> float:
    """R's ``.psignrank(q)``: P(V* <= q), with R's tolerance on the support ``s/f``."""
    support = np.arange(density.size) / scale
    return float(density[support < q + _SQRT_EPS].sum())


def _exact_p(v: float, ranks: Sequence[float]) -> float:
    n = len(ranks)
    density, scale = null_distribution(ranks)
    if v > n * (n + 1) / 4:
        p = 1.0 - _lower_tail(v - 1, density, scale)
    else:
        p = _lower_tail(v, density, scale)
    return min(2 * p, 1.0)


def _normal_p(v: float, ranks: Sequence[float]) -> float:
    n = len(ranks)
    ties = sum(t**3 - t for t in Counter(ranks).values())
    sigma = math.sqrt(n * (n + 1) * (2 * n + 1) / 24 - ties / 48)
    centred = v - n * (n + 1) / 4
    correction = math.copysign(0.5, centred) if centred != 0 else 0.0
    z = (centred - correction) / sigma
    return float(2 * min(ndtr(z), ndtr(-z)))
