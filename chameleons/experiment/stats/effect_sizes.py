"""Effect sizes with seeded bootstrap confidence intervals, per measure.

- **Kendall's W** (the Friedman test's effect size, tie-corrected: ``W = chi2 / (n (k-1))``).
- Per pair of conditions (a, b), over the same participants:
  the **matched-pairs rank-biserial correlation** ``r = (T+ - T-) / (T+ + T-)`` (Kerby's
  simple difference formula; ``T+``/``T-`` are the Wilcoxon signed-rank sums of the
  positive/negative differences a - b), computed from the very differences and ranks the
  post-hoc test's V comes from (:mod:`.wilcoxon`, R's rules: zero differences dropped,
  magnitudes compared as the doubles R sees), so ``r = 2 V / (n (n + 1) / 2) - 1`` with
  ``n`` the non-zero differences; and the **median of the paired differences** a - b.

Intervals are percentile intervals of ``scipy.stats.bootstrap`` resampling participants
(rows stay paired), as R's ``rcompanion::kendallW`` does by default (``type = "perc"``).
BCa was tried and rejected: W sits at its boundary 0 when the conditions do not differ,
and BCa's bias correction then shrinks the interval to a misleading sliver near 0. Every
interval has its own generator seeded from ``(seed, what it measures)``, so the same data,
seed and number of resamples give the same interval, whatever else is computed.

A percentile interval of zero width (both ends equal: at least 95% of the resamples gave
the same value, typical of a median difference of 0-3 counts) does not describe the
uncertainty; it is flagged (``degenerate``) and the reports say so.
"""

from __future__ import annotations

import warnings
import zlib
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from itertools import combinations
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from scipy.stats import bootstrap, rankdata

from chameleons.experiment.stats.wilcoxon import signed_rank_test

Method = Literal["BCa", "percentile"]
Array = NDArray[np.float64]
DEFAULT_RESAMPLES = 2000
CONFIDENCE = 0.95
DEGENERATE_NOTE = (
    "zero-width interval: at least 95% of the resamples gave this value, so the bootstrap "
    "cannot show the uncertainty"
)


@dataclass(frozen=True)
class BootstrapOptions:
    resamples: int = DEFAULT_RESAMPLES
    seed: int = 0
    confidence: float = CONFIDENCE


@dataclass(frozen=True)
class Interval:
    """An estimate with its bootstrap interval (bounds ``None`` when not computable)."""

    estimate: float | None
    ci_low: float | None
    ci_high: float | None
    method: str
    note: str = ""
    degenerate: bool = False  # both ends equal: the interval says nothing about precision


@dataclass(frozen=True)
class PairEffect:
    a: str
    b: str
    n: int
    n_nonzero: int
    rank_biserial: Interval
    median_difference: Interval


@dataclass(frozen=True)
class EffectSizes:
    n: int
    confidence: float
    resamples: int
    seed: int
    kendall_w: Interval
    pairs: list[PairEffect] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def kendall_w_batch(values: Array) -> Array:
    """Tie-corrected Kendall's W of ``values`` shaped (..., n, k); 0 where every block ties."""
    n, k = values.shape[-2], values.shape[-1]
    # Average ranks within each block by counting (k is small): 1 + below + (equal - 1) / 2.
    left, right = values[..., :, :, None], values[..., :, None, :]
    below = (right < left).sum(axis=-1)
    equal = (right == left).sum(axis=-1).astype(np.float64)
    ranks = 1 + below + (equal - 1) / 2
    spread = ((ranks.sum(axis=-2) - n * (k + 1) / 2) ** 2).sum(axis=-1)
    ties = (equal**2 - 1).sum(axis=(-1, -2))  # each tie group of t adds t (t^2 - 1) = t^3 - t
    denominator = n * n * (k**3 - k) - n * ties
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(denominator > 0, 12 * spread / denominator, 0.0)
    return np.asarray(w, dtype=np.float64)


def rank_biserial_batch(differences: Array) -> Array:
    """Matched-pairs rank-biserial r of ``differences`` (..., n); 0 where all are zero.
    The differences are used as they are (no rounding), as the signed-rank test's V is."""
    magnitudes = np.abs(differences)
    zeros = (differences == 0).sum(axis=-1, keepdims=True)
    # Zeros share the lowest ranks, so the non-zero ranks are the overall ranks minus them.
    ranks = rankdata(magnitudes, axis=-1) - zeros
    positive = np.where(differences > 0, ranks, 0.0).sum(axis=-1)
    negative = np.where(differences < 0, ranks, 0.0).sum(axis=-1)
    total = positive + negative
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(total > 0, (positive - negative) / total, 0.0)
    return np.asarray(r, dtype=np.float64)


def _seed_for(seed: int, key: str) -> np.random.Generator:
    return np.random.default_rng([seed, zlib.crc32(key.encode())])


def bootstrap_interval(
    columns: Sequence[Array],
    statistic: Callable[..., Array],
    options: BootstrapOptions,
    key: str,
    method: Method,
) -> tuple[float | None, float | None, str, str]:
    """(low, high, method used, note) of a paired bootstrap over the rows of ``columns``."""

    def run(how: Method) -> tuple[float, float, list[str]]:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = bootstrap(
                tuple(columns),
                statistic,
                n_resamples=options.resamples,
                vectorized=True,
                paired=True,
                axis=-1,
                confidence_level=options.confidence,
                method=how,
                rng=_seed_for(options.seed, key),
            )
        interval = result.confidence_interval
        return float(interval.low), float(interval.high), [str(w.message) for w in caught]

    low, high, messages = run(method)
    if method == "BCa" and not (np.isfinite(low) and np.isfinite(high)):
        low, high, _ = run("percentile")
        return low, high, "percentile", "BCa not computable (degenerate bootstrap); percentile"
    if not (np.isfinite(low) and np.isfinite(high)):
        return None, None, method, "; ".join(messages) or "interval not computable"
    return low, high, method, ""


def _w_statistic(*columns: Array, axis: int = -1) -> Array:
    stacked = np.stack([np.moveaxis(c, axis, -1) for c in columns], axis=-1)
    return kendall_w_batch(stacked)


def _r_statistic(a: Array, b: Array, axis: int = -1) -> Array:
    return rank_biserial_batch(np.moveaxis(a - b, axis, -1))


def _median_statistic(a: Array, b: Array, axis: int = -1) -> Array:
    return np.asarray(np.median(a - b, axis=axis), dtype=np.float64)


def effect_sizes(
    blocks: Sequence[Sequence[float]],
    conditions: Sequence[str],
    options: BootstrapOptions,
    key: str = "",
) -> EffectSizes:
    """Kendall's W and the pairwise effects of ``blocks`` (participants x conditions)."""
    data = np.asarray(blocks, dtype=np.float64).reshape(len(blocks), len(conditions))
    n = data.shape[0]
    columns = [data[:, j] for j in range(len(conditions))]
    w = _kendall_w(data, columns, options, key)
    pairs = [
        _pair(conditions[i], conditions[j], columns[i], columns[j], options, key)
        for i, j in combinations(range(len(conditions)), 2)
    ]
    return EffectSizes(n, options.confidence, options.resamples, options.seed, w, pairs)


def _kendall_w(data: Array, columns: list[Array], options: BootstrapOptions, key: str) -> Interval:
    how = "percentile bootstrap over participants"
    if data.shape[0] < 2 or data.shape[1] < 2:
        return Interval(None, None, None, how, "needs at least 2 participants")
    if _all_tied(data):
        return Interval(None, None, None, how, "undefined: every participant's values are tied")
    estimate = float(kendall_w_batch(data[None])[0])
    low, high, method, note = bootstrap_interval(
        columns, _w_statistic, options, f"{key}:W", "percentile"
    )
    return _interval(estimate, low, high, method, note)


def _all_tied(data: Array) -> bool:
    return bool((data == data[:, :1]).all())


def _interval(
    estimate: float, low: float | None, high: float | None, method: str, note: str
) -> Interval:
    """The estimate and its interval, flagged when the interval has zero width."""
    how = f"{method} bootstrap over participants"
    if low is not None and high is not None and low == high:
        return Interval(estimate, low, high, how, note or DEGENERATE_NOTE, degenerate=True)
    return Interval(estimate, low, high, how, note)


def _pair(a: str, b: str, x: Array, y: Array, options: BootstrapOptions, key: str) -> PairEffect:
    differences = x - y
    n = len(differences)
    test = signed_rank_test(list(x), list(y))  # R's V, zeros and ranks
    if n < 2:
        empty = Interval(None, None, None, "", "needs at least 2 participants")
        return PairEffect(a, b, n, test.n, empty, empty)
    median = float(np.median(differences))
    low, high, method, note = bootstrap_interval(
        [x, y], _median_statistic, options, f"{key}:{a}-{b}:median", "percentile"
    )
    median_interval = _interval(median, low, high, method, note)
    if test.n == 0:
        undefined = Interval(None, None, None, "", "undefined: all differences are zero")
        return PairEffect(a, b, n, 0, undefined, median_interval)
    r = 2 * test.v / (test.n * (test.n + 1) / 2) - 1
    low, high, method, note = bootstrap_interval(
        [x, y], _r_statistic, options, f"{key}:{a}-{b}:r", "percentile"
    )
    return PairEffect(a, b, n, test.n, _interval(r, low, high, method, note), median_interval)
