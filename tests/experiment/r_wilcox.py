"""An independent reference for R's ``wilcox.test(x, y, paired = TRUE)`` (two-sided,
``correct = TRUE``, ``exact = NULL``), written from R's documented rules and its source
(``src/library/stats/R/wilcox.test.R`` of R 4.5 and of R 4.6, read in the wch/r-source
mirror) without sharing code with ``chameleons.experiment.stats.wilcoxon``:

- drop zero differences; rank ``|d|`` (ties: mean rank); ``V`` = rank sum of ``d > 0``;
- exact when ``n < 50`` and no zeros (R < 4.6: and no ties); two-sided
  ``p = min(1, 2 * (P(V* <= V) if V <= n(n+1)/4 else 1 - P(V* <= V - 1)))``;
- else ``z = (V - n(n+1)/4 - sign/2) / sqrt(n(n+1)(2n+1)/24 - sum(t^3 - t)/48)`` and
  ``p = 2 * min(Phi(z), 1 - Phi(z))``.

The null distribution is counted with Python integers (exact), by brute-force enumeration
of every sign pattern for small n and by a dictionary convolution otherwise.
"""

from __future__ import annotations

import itertools
from collections import Counter
from fractions import Fraction
from statistics import NormalDist


def midranks(values: list[float]) -> list[Fraction]:
    """rank(): each value's rank is (#smaller) + (#equal + 1) / 2."""
    return [
        Fraction(sum(1 for w in values if w < v))
        + Fraction(sum(1 for w in values if w == v) + 1, 2)
        for v in values
    ]


def null_counts(ranks: list[Fraction], brute_force: bool) -> Counter[Fraction]:
    """How many of the 2^n sign patterns give each value of V."""
    if brute_force:
        counts: Counter[Fraction] = Counter()
        for signs in itertools.product((0, 1), repeat=len(ranks)):
            counts[sum((r for r, s in zip(ranks, signs, strict=True) if s), Fraction(0))] += 1
        return counts
    counts = Counter({Fraction(0): 1})
    for rank in ranks:
        following: Counter[Fraction] = Counter()
        for value, ways in counts.items():
            following[value] += ways
            following[value + rank] += ways
        counts = following
    return counts


def r_wilcox_paired(
    x: list[float], y: list[float], rule: str = "R<4.6"
) -> tuple[float | None, float | None, str]:
    """(V, p, "exact" | "normal"); (None, None, "") when every difference is zero."""
    d = [a - b for a, b in zip(x, y, strict=True)]
    zero = any(v == 0 for v in d)
    d = [v for v in d if v != 0]
    n = len(d)
    if n == 0:
        return None, None, ""
    ranks = midranks([abs(v) for v in d])
    v_stat = sum((r for r, v in zip(ranks, d, strict=True) if v > 0), Fraction(0))
    ties = len(set(ranks)) < n
    exact = n < 50 and not zero and (rule == "R>=4.6" or not ties)
    if exact:
        counts = null_counts(ranks, brute_force=n <= 12)
        total = 2**n

        def at_most(q: Fraction) -> Fraction:
            return Fraction(sum(w for value, w in counts.items() if value <= q), total)

        half = Fraction(n * (n + 1), 4)
        p = at_most(v_stat) if v_stat <= half else 1 - at_most(v_stat - 1)
        return float(v_stat), float(min(2 * p, Fraction(1))), "exact"
    ties_term = sum(t**3 - t for t in Counter(ranks).values())
    sigma = (Fraction(n * (n + 1) * (2 * n + 1), 24) - Fraction(ties_term, 48)) ** 0.5
    centred = float(v_stat - Fraction(n * (n + 1), 4))
    correction = 0.5 if centred > 0 else -0.5 if centred < 0 else 0.0
    z = (centred - correction) / float(sigma)
    normal = NormalDist()
    return float(v_stat), 2 * min(normal.cdf(z), 1 - normal.cdf(z)), "normal"
