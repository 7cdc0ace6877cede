"""Internal consistency of a questionnaire scale: Cronbach's alpha with Feldt's interval.

``alpha = k / (k - 1) * (1 - sum of the item variances / variance of the sum score)``
(Cronbach 1951), sample variances (ddof = 1), over the complete cases (every item of the
scale answered), reverse-keyed items reversed first. The confidence interval is Feldt's
F-based one (Feldt, Woodruff & Salih 1987, formulas 6 and 7, as R's ``cocron`` and
Python's ``pingouin`` compute it): with ``n`` cases and ``k`` items, ``df1 = n - 1`` and
``df2 = (n - 1)(k - 1)``, lower ``1 - (1 - alpha) F(1 - c/2)``, upper
``1 - (1 - alpha) F(c/2)``. "Alpha if item deleted" is alpha of the other items.

Feldt's interval assumes independent cases. When each participant rated several robots
(one case per condition), the cases of one participant are not independent: then
:func:`cluster_bootstrap_interval` gives the pooled alpha a percentile interval that
resamples *participants* (with all their ratings), and alpha per condition (one case per
participant, so independent) keeps Feldt's interval.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy.stats import f as f_distribution

CONFIDENCE = 0.95
FELDT = "Feldt"
CLUSTER_BOOTSTRAP = "percentile bootstrap over participants"
DEFAULT_RESAMPLES = 2000


@dataclass(frozen=True)
class Reliability:
    """Cronbach's alpha of one scale; ``alpha`` is None when undefined (fewer than two
    items or cases, or no variance in the sum score)."""

    scale: str
    items: int
    n: int
    alpha: float | None
    ci_low: float | None
    ci_high: float | None
    confidence: float = CONFIDENCE
    if_deleted: dict[str, float | None] = field(default_factory=dict)
    note: str = ""
    method: str = FELDT  # how the interval was computed
    condition: str = ""  # set for alpha within one condition
    participants: int = 0  # distinct participants among the cases (0: not known)
    by_condition: list[Reliability] = field(default_factory=list)

    def to_dict(self) -> dict[str, object]:
        return asdict(self)

    @property
    def best_drop(self) -> tuple[str, float] | None:
        """The item whose removal raises alpha most, with that alpha (a weak item shows)."""
        defined = [(a, item) for item, a in self.if_deleted.items() if a is not None]
        if not defined:
            return None
        value, item = max(defined)
        return item, value


NO_VARIANCE = 1e-9  # relative to the item variances: below it the sum score is constant


def alpha_from_covariance(covariance: np.ndarray) -> float | None:
    """Cronbach's alpha from the items' covariance matrix (None when undefined)."""
    matrix = np.asarray(covariance, dtype=float)
    k = matrix.shape[0]
    total = float(matrix.sum())
    # A sum score that does not vary comes out of the covariance a few units of rounding
    # from zero, either side (answers 1,3,3 / 1,5,1 / 1,5,1: 1.1e-16, alpha -1.8e16).
    zero = NO_VARIANCE * max(float(np.trace(matrix)), 1.0)
    if k < 2 or not math.isfinite(total) or total <= zero:
        return None
    return float(k / (k - 1) * (1.0 - float(np.trace(matrix)) / total))


def feldt_interval(
    alpha: float, n: int, k: int, confidence: float = CONFIDENCE
) -> tuple[float | None, float | None]:
    """Feldt's confidence interval for ``alpha`` from ``n`` cases and ``k`` items."""
    if n < 2 or k < 2:
        return None, None
    df1, df2 = n - 1, (n - 1) * (k - 1)
    tail = (1.0 - confidence) / 2.0
    low = 1.0 - (1.0 - alpha) * float(f_distribution.ppf(1.0 - tail, df1, df2))
    high = 1.0 - (1.0 - alpha) * float(f_distribution.ppf(tail, df1, df2))
    return low, high


def cronbach_alpha(
    scale: str,
    item_ids: Sequence[str],
    cases: Sequence[Sequence[float]],
    confidence: float = CONFIDENCE,
) -> Reliability:
    """Alpha of ``cases`` (each a complete vector of the items' scored values, in
    ``item_ids`` order), with its interval and alpha-if-item-deleted."""
    k, n = len(item_ids), len(cases)
    if k < 2 or n < 2:
        why = "needs two items or more" if k < 2 else "needs two complete cases or more"
        return Reliability(scale, k, n, None, None, None, confidence, note=why)
    data = np.asarray(cases, dtype=float)
    covariance = np.cov(data, rowvar=False, ddof=1)
    alpha = alpha_from_covariance(covariance)
    if alpha is None:
        note = "undefined: the sum score does not vary"
        return Reliability(scale, k, n, None, None, None, confidence, note=note)
    low, high = feldt_interval(alpha, n, k, confidence)
    deleted = {
        item: alpha_from_covariance(np.delete(np.delete(covariance, i, 0), i, 1))
        for i, item in enumerate(item_ids)
    }
    return Reliability(scale, k, n, alpha, low, high, confidence, deleted)


def cluster_bootstrap_interval(
    cases: Sequence[Sequence[float]],
    clusters: Sequence[str],
    *,
    resamples: int = DEFAULT_RESAMPLES,
    seed: int = 0,
    key: str = "",
    confidence: float = CONFIDENCE,
) -> tuple[float | None, float | None, str]:
    """Percentile interval of alpha resampling the ``clusters`` (participants) with
    replacement, each with all its cases; the generator is seeded from ``(seed, key)``.
    Returns (low, high, note); resamples whose alpha is undefined are left out (counted).

    Every resample's alpha comes from per-participant sums (of each item, of its squares,
    of the sum score and of its square), weighted by how often the participant was drawn:
    the same numbers as the covariance of the resampled cases, without building them."""
    data = np.asarray(cases, dtype=float)
    names = sorted(set(clusters))
    if len(names) < 2:
        return None, None, "needs two participants or more"
    index = np.array([names.index(c) for c in clusters])
    totals = data.sum(axis=1)
    per = np.zeros((len(names), 2 * data.shape[1] + 3))
    k = data.shape[1]
    np.add.at(per[:, :k], index, data)
    np.add.at(per[:, k : 2 * k], index, data**2)
    np.add.at(per[:, 2 * k], index, totals)
    np.add.at(per[:, 2 * k + 1], index, totals**2)
    np.add.at(per[:, 2 * k + 2], index, 1.0)
    rng = np.random.default_rng([seed, zlib.crc32(f"alpha:{key}".encode())])
    draws = rng.integers(0, len(names), size=(resamples, len(names)))
    weights = np.zeros((resamples, len(names)))
    np.add.at(weights, (np.arange(resamples)[:, None], draws), 1.0)
    sums = weights @ per
    n = sums[:, 2 * k + 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        item_variances = (sums[:, k : 2 * k] - sums[:, :k] ** 2 / n[:, None]) / (n - 1)[:, None]
        trace = item_variances.sum(axis=1)
        total = (sums[:, 2 * k + 1] - sums[:, 2 * k] ** 2 / n) / (n - 1)
        values = k / (k - 1) * (1.0 - trace / total)
    values[(n < 2) | ~(total > NO_VARIANCE * np.maximum(trace, 1.0))] = np.nan
    finite = values[np.isfinite(values)]
    if len(finite) < resamples / 2:
        return None, None, "alpha undefined in most resamples"
    tail = (1 - confidence) / 2
    low, high = np.quantile(finite, [tail, 1 - tail])
    note = ""
    if len(finite) < resamples:
        note = f"{resamples - len(finite)} of {resamples} resamples had no defined alpha"
    return float(low), float(high), note
