"""The Friedman test, written out from its formula, with an exact / permutation p-value.

For ``n`` blocks (participants) and ``k`` treatments (conditions), values are ranked within
each block (ties get their average rank) and ``R_j`` is the rank sum of treatment ``j``::

    chi2 = (12 / (n k (k + 1)) * sum_j R_j^2 - 3 n (k + 1)) / C
    C    = 1 - sum_blocks sum_tie_groups (t^3 - t) / (n k (k^2 - 1))

(the tie correction of R's ``friedman.test`` and SciPy's ``friedmanchisquare``). The
asymptotic p-value is the chi-squared tail with ``k - 1`` degrees of freedom; Kendall's
``W = chi2 / (n (k - 1))``. When every block is entirely tied, ``C = 0``: nothing
distinguishes the treatments and the statistic is *undefined* (``None``), never 0.

The permutation p-value conditions on the observed within-block ranks: under the null
hypothesis every ordering of a block's ranks is equally likely. It is computed *exactly*
(up to floating-point rounding) by convolving the blocks' rank vectors when that is cheap
(3 conditions: up to 64 participants; 4: up to 8; about 0.1 s per measure at most, since
the analysis page computes it on every first render), otherwise by Monte Carlo with
a seeded generator
(``p = (1 + #{S* >= S}) / (1 + resamples)``).
"""

from __future__ import annotations

import itertools
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from math import factorial

import numpy as np
from scipy.stats import chi2 as chi2_distribution

MAX_EXACT_WORK = 20_000_000  # grid cells x arrangements, summed over the blocks


def exact_work(n: int, k: int) -> int:
    """The exact convolution's work for n participants and k conditions: block i touches a
    grid of (i 2k + 1)^(k - 1) cells once per ordering of its ranks. ``analysis.R`` uses
    the same formula and limit, so both compute the same kind of p."""
    return int(sum((i * 2 * k + 1) ** (k - 1) for i in range(1, n + 1))) * factorial(k)


@dataclass(frozen=True)
class FriedmanResult:
    n: int
    k: int
    chi2: float | None  # None: undefined (every block tied, or no complete block)
    df: int
    p: float | None
    kendall_w: float | None


@dataclass(frozen=True)
class PermutationResult:
    p: float | None
    method: str  # "exact" or "monte-carlo"
    resamples: int | None  # Monte Carlo only
    seed: int | None  # Monte Carlo only


def average_ranks(values: Sequence[float]) -> list[float]:
    """Ranks 1..len(values); tied values share the mean of the ranks they occupy."""
    order = sorted(range(len(values)), key=lambda i: values[i])
    ranks = [0.0] * len(values)
    start = 0
    while start < len(order):
        end = start
        while end + 1 < len(order) and values[order[end + 1]] == values[order[start]]:
            end += 1
        for position in range(start, end + 1):
            ranks[order[position]] = (start + end) / 2 + 1
        start = end + 1
    return ranks


def friedman(blocks: Sequence[Sequence[float]]) -> FriedmanResult:
    """Friedman test over ``blocks`` (one row per participant, one column per condition)."""
    n = len(blocks)
    k = len(blocks[0]) if blocks else 0
    if any(len(block) != k for block in blocks):
        raise ValueError("every block needs one value per condition")
    df = max(k - 1, 0)
    if n == 0 or k < 2:
        return FriedmanResult(n, k, None, df, None, None)
    ranks = [average_ranks(block) for block in blocks]
    rank_sums = [sum(column) for column in zip(*ranks, strict=True)]
    ties = sum(t**3 - t for block in blocks for t in Counter(block).values())
    correction = 1 - ties / (n * k * (k * k - 1))
    if correction <= 1e-12:
        return FriedmanResult(n, k, None, df, None, None)
    spread = 12 / (n * k * (k + 1)) * sum(r * r for r in rank_sums) - 3 * n * (k + 1)
    chi2 = max(spread / correction, 0.0)  # rounding must not make it negative
    p = float(chi2_distribution.sf(chi2, df))
    return FriedmanResult(n, k, chi2, df, p, chi2 / (n * (k - 1)))


def permutation_p(
    blocks: Sequence[Sequence[float]], *, resamples: int = 10_000, seed: int = 0
) -> PermutationResult:
    """P(S >= observed S) for ``S = sum_j R_j^2`` under within-block permutation (exact
    when feasible, else Monte Carlo). Undefined (``None``) when the test is."""
    if friedman(blocks).chi2 is None:
        return PermutationResult(None, "exact", None, None)
    doubled = [tuple(round(2 * r) for r in average_ranks(block)) for block in blocks]
    observed = sum(s * s for s in map(sum, zip(*doubled, strict=True)))
    exact = _exact_p(doubled, observed)
    if exact is not None:
        return PermutationResult(exact, "exact", None, None)
    return PermutationResult(
        _monte_carlo_p(doubled, observed, resamples, seed), "monte-carlo", resamples, seed
    )


def _exact_p(doubled: list[tuple[int, ...]], observed: int) -> float | None:
    """Convolve the null distribution of the rank-sum vector block by block on a grid of
    the first k - 1 (doubled) rank sums; the last is fixed by the total. The grid grows
    with the sums reached so far (block i reaches at most i times the largest rank).
    ``None`` when the work would be too large (then Monte Carlo is used)."""
    n, k = len(doubled), len(doubled[0])
    if exact_work(n, k) > MAX_EXACT_WORK:
        return None
    grid = np.ones((1,) * (k - 1))
    for block in doubled:
        reach = grid.shape[0] - 1
        following = np.zeros((reach + max(block) + 1,) * (k - 1))
        for arrangement, ways in Counter(itertools.permutations(block)).items():
            target = tuple(slice(s, s + reach + 1) for s in arrangement[:-1])
            following[target] += grid * (ways / factorial(k))
        grid = following
    sums = np.indices(grid.shape)
    last = n * k * (k + 1) - sums.sum(axis=0)  # each block's doubled ranks add to k(k+1)
    statistic = (sums**2).sum(axis=0) + last**2
    return float(min(1.0, grid[statistic >= observed].sum()))


def _monte_carlo_p(
    doubled: list[tuple[int, ...]], observed: int, resamples: int, seed: int
) -> float:
    """Each resample draws one of the k! orderings per participant (an index into their
    orderings, uniformly: the same law as shuffling their ranks)."""
    rng = np.random.default_rng(seed)
    ranks = np.array(doubled, dtype=np.int64)
    n, k = ranks.shape
    orders = np.array(list(itertools.permutations(range(k))), dtype=np.intp)  # (k!, k)
    arranged = ranks[:, orders]  # (n, k!, k): every ordering of every participant's ranks
    people = np.arange(n)[None, :]
    at_least = 0
    for start in range(0, resamples, 2_000):  # chunks keep memory small
        size = min(2_000, resamples - start)
        chosen = rng.integers(0, len(orders), size=(size, n))
        sums = arranged[people, chosen].sum(axis=1)  # (size, k)
        at_least += int(((sums * sums).sum(axis=1) >= observed).sum())
    return (1 + at_least) / (1 + resamples)
