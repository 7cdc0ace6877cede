"""Windowed lagged cross-correlation as rMEA's ``MEAccf`` computes it (Kleinbub & Ramseyer
2020, rMEA 1.2, ``R/rMEA_ccf.R``), vectorised over channels, windows and lags.

For a window size ``win``, an increment ``inc`` and a lag range ``lag`` (all in samples),
with ``N`` samples: ``ceil((N - win - lag + 1) / inc)`` windows, window ``w`` covering the
``win + lag`` samples from ``w * inc``. In a window, lag ``k >= 0`` correlates
``x[0:win]`` with ``y[k:k + win]`` (high values at positive lags: ``y`` follows ``x``); lag
``-k`` correlates ``x[k:k + win]`` with ``y[0:win]``. A window where either series misses
more than half of its samples is missing at every lag; otherwise each correlation is
Pearson's over the complete pairs (R's ``cor(..., use = "complete.obs")``). Correlations go
to Fisher's z (``atanh``, bounded to +-10) and then to absolute values (``r2Z = TRUE``,
``ABS = TRUE``, rMEA's defaults).

Two departures, both documented in docs/science.md: rMEA returns NA when fewer than two
complete pairs differ (``sum(x != y) < 2``), which also drops a perfect copy (identical
values at that lag); here a correlation is missing when fewer than three complete pairs
exist or either side does not vary (R's ``cor`` gives NA for a zero standard deviation:
"does not vary" is a variance below 1e-10 of the window's squared range, so floating-point
residue of a constant is not taken for movement).

The sums each correlation needs (pairs, sums, sums of squares and of products over the
complete pairs) are cross-correlations of the masked series, computed with real FFTs of one
window at a time for all lags at once; every window is centred on its own mean first, so
the sums stay well conditioned.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import fft

Array = npt.NDArray[np.float64]
Z_BOUND = 10.0  # rMEA's fisher.r2z bounds z to +-10
FLAT = 1e-10  # variance below this share of the squared range: no movement
MIN_PAIRS = 3
BLOCK_ROWS = 256  # (channel, window) rows per FFT batch: bounded memory


@dataclass(frozen=True)
class Layout:
    """Window, increment and lag range in samples, and the number of windows."""

    win: int
    inc: int
    lag: int
    n_windows: int

    @property
    def lags(self) -> npt.NDArray[np.int64]:
        return np.arange(-self.lag, self.lag + 1)

    @property
    def span(self) -> int:
        """Samples one window reads."""
        return self.win + self.lag


def layout(n_samples: int, win: int, inc: int, lag: int) -> Layout:
    if win < MIN_PAIRS or inc < 1 or lag < 0:
        raise ValueError(f"window {win}, increment {inc} and lag {lag} samples do not fit")
    windows = max(0, math.ceil((n_samples - win - lag + 1) / inc))
    return Layout(win, inc, lag, windows)


def windowed_ccf(x: Array, y: Array, win: int, inc: int, lag: int) -> Array:
    """|Fisher z| per channel, window and lag: ``x`` and ``y`` are ``(channels, samples)``
    (NaN = missing); the result is ``(channels, windows, 2 * lag + 1)``, lags from ``-lag``
    to ``+lag``, NaN where a correlation is missing."""
    x = np.atleast_2d(np.asarray(x, dtype=np.float64))
    y = np.atleast_2d(np.asarray(y, dtype=np.float64))
    if x.shape != y.shape:
        raise ValueError(f"the two series differ in shape: {x.shape} and {y.shape}")
    shape = layout(x.shape[1], win, inc, lag)
    channels = x.shape[0]
    out = np.full((channels, shape.n_windows, 2 * lag + 1), np.nan)
    if shape.n_windows == 0 or channels == 0:
        return out
    starts = np.arange(shape.n_windows) * inc
    index = starts[:, None] + np.arange(shape.span)[None, :]  # (windows, span)
    xs = x[:, index].reshape(-1, shape.span)  # rows: channel-major (channel, window)
    ys = y[:, index].reshape(-1, shape.span)
    result = out.reshape(-1, 2 * lag + 1)
    for first in range(0, xs.shape[0], BLOCK_ROWS):
        rows = slice(first, first + BLOCK_ROWS)
        result[rows] = _block(xs[rows], ys[rows], win, lag)
    return out


def _block(xs: Array, ys: Array, win: int, lag: int) -> Array:
    """|z| for rows of windows (each ``win + lag`` samples long), all lags."""
    missing_x, missing_y = np.isnan(xs), np.isnan(ys)
    holes = missing_x.any(1) | missing_y.any(1)
    out = np.empty((xs.shape[0], 2 * lag + 1))
    if (~holes).any():  # the usual case, without the masks' extra passes
        x, y = xs[~holes], ys[~holes]
        x0, y0 = x - x.mean(1, keepdims=True), y - y.mean(1, keepdims=True)
        sums = _complete_sums(x0, y0, win, lag)
        out[~holes] = _z(sums, np.ptp(x, 1), np.ptp(y, 1), np.zeros(len(x), dtype=bool))
    if holes.any():
        out[holes] = _gappy(xs[holes], ys[holes], missing_x[holes], missing_y[holes], win, lag)
    return out


def _gappy(xs: Array, ys: Array, missing_x: npt.NDArray[np.bool_],
           missing_y: npt.NDArray[np.bool_], win: int, lag: int) -> Array:  # fmt: skip
    """Rows with missing samples: sums over the complete pairs only."""
    span = win + lag
    too_sparse = np.maximum(missing_x.sum(1), missing_y.sum(1)) > span / 2  # rMEA's NA rule
    mx, my = (~missing_x).astype(np.float64), (~missing_y).astype(np.float64)
    with np.errstate(invalid="ignore"):  # all-missing rows: their centre is NaN, set to 0
        cx = np.nan_to_num(np.nanmean(np.where(too_sparse[:, None], 0.0, xs), axis=1))
        cy = np.nan_to_num(np.nanmean(np.where(too_sparse[:, None], 0.0, ys), axis=1))
    x0 = np.where(missing_x, 0.0, xs - cx[:, None])
    y0 = np.where(missing_y, 0.0, ys - cy[:, None])
    sums = _masked_sums(x0, mx, y0, my, win, lag)
    return _z(sums, _range(xs, missing_x), _range(ys, missing_y), too_sparse)


def _z(sums: Array, range_x: Array, range_y: Array, too_sparse: npt.NDArray[np.bool_]) -> Array:
    """|Fisher z| from the sums ``(n, sx, sxx, sy, syy, sxy)``; NaN where missing."""
    n, sx, sxx, sy, syy, sxy = sums
    n = np.rint(n)
    with np.errstate(invalid="ignore", divide="ignore"):
        vx = sxx - sx * sx / n
        vy = syy - sy * sy / n
        r = (sxy - sx * sy / n) / np.sqrt(vx * vy)
    flat = _flat(vx, n, range_x) | _flat(vy, n, range_y)
    bad = (n < MIN_PAIRS) | flat | too_sparse[:, None] | ~np.isfinite(r)
    r = np.clip(np.where(bad, 0.0, r), -1.0, 1.0)
    with np.errstate(divide="ignore"):
        z = np.clip(np.arctanh(r), -Z_BOUND, Z_BOUND)
    return np.where(bad, np.nan, np.abs(z))


def _range(rows: Array, missing: npt.NDArray[np.bool_]) -> Array:
    """Each row's range over its present samples (-inf for a row with none)."""
    high = np.max(np.where(missing, -np.inf, rows), axis=1)
    low = np.min(np.where(missing, np.inf, rows), axis=1)
    with np.errstate(invalid="ignore"):
        return np.asarray(high - low)


def _flat(variation: Array, n: Array, spread: Array) -> npt.NDArray[np.bool_]:
    """Where a side does not vary: its variation (sum of squared deviations) is at most
    ``FLAT`` of its pairs times the window's squared range (exactly constant: range 0)."""
    square = np.square(spread)[:, None]
    constant = ~(square > 0)
    return np.asarray(constant | (variation <= FLAT * n * square))


def _masked_sums(x: Array, mx: Array, y: Array, my: Array, win: int, lag: int) -> Array:
    """``(n, sx, sxx, sy, syy, sxy)`` per row and lag (-lag..lag) over the complete pairs."""
    positive = _sums(x, mx, y, my, win, lag)  # x[0:win] with y[k:k+win], k = 0..lag
    negative = _sums(y, my, x, mx, win, lag)  # y[0:win] with x[k:k+win]: lag -k
    order = (0, 3, 4, 1, 2, 5)  # the negative side's sums come with the roles swapped
    return np.stack([np.concatenate([negative[o][:, :0:-1], positive[i]], axis=1)
                     for i, o in enumerate(order)])  # fmt: skip


def _complete_sums(x: Array, y: Array, win: int, lag: int) -> Array:
    """The same for rows without a missing sample: every pair counts, so the sums of one
    side are running sums; only the cross products need a correlation."""
    rows, span = x.shape
    size = fft.next_fast_len(span, real=True)
    shifted_x, shifted_xx = _shifted(x, win, lag), _shifted(x * x, win, lag)
    shifted_y, shifted_yy = _shifted(y, win, lag), _shifted(y * y, win, lag)
    # rfft pads with zeros: the first ``win`` samples are the window's head
    x_head, y_head = fft.rfft(x[:, :win], size, axis=-1), fft.rfft(y[:, :win], size, axis=-1)
    x_all, y_all = fft.rfft(x, size, axis=-1), fft.rfft(y, size, axis=-1)
    cross = fft.irfft(np.stack([np.conj(x_head) * y_all, np.conj(y_head) * x_all]), size,
                      axis=-1)[..., : lag + 1]  # x head * y, y head * x  # fmt: skip
    both = np.concatenate
    ones = np.ones((rows, 2 * lag + 1))
    return np.stack([
        ones * win,
        both([shifted_x[:, :0:-1], np.repeat(shifted_x[:, :1], lag + 1, 1)], axis=1),
        both([shifted_xx[:, :0:-1], np.repeat(shifted_xx[:, :1], lag + 1, 1)], axis=1),
        both([np.repeat(shifted_y[:, :1], lag, 1), shifted_y], axis=1),
        both([np.repeat(shifted_yy[:, :1], lag, 1), shifted_yy], axis=1),
        both([cross[1][:, :0:-1], cross[0]], axis=1),
    ])  # fmt: skip


def _shifted(values: Array, win: int, lag: int) -> Array:
    """``sum(values[:, k:k + win])`` for ``k = 0..lag`` (rows of ``win + lag`` samples): the
    first window's sum, then each shift adds the sample entering and drops the one leaving
    (running sums over the ``lag`` samples at either end only)."""
    first = values[:, :win].sum(axis=1, keepdims=True)
    steps = values[:, win : win + lag] - values[:, :lag]
    return np.concatenate([first, first + np.cumsum(steps, axis=1)], axis=1)


def _sums(
    a: Array, ma: Array, b: Array, mb: Array, win: int, lag: int
) -> tuple[Array, Array, Array, Array, Array, Array]:
    """Over the complete pairs ``(a[i], b[i + k])``, ``i < win``, for ``k = 0..lag``: the
    pairs, sum a, sum a^2, sum b, sum b^2 and sum a*b (rows independent)."""
    span = a.shape[1]
    size = fft.next_fast_len(span, real=True)
    head = np.zeros_like(a)
    head[:, :win] = 1.0
    a_head, ma_head = a * head, ma * head
    left = fft.rfft(np.stack([ma_head, a_head, a_head * a_head]), size, axis=-1)
    right = fft.rfft(np.stack([mb, b, b * b]), size, axis=-1)
    conj = np.conj(left)
    # sum_i L[i] R[i + k] = irfft(conj(F L) * F R)[k]; i + k < span <= size: no wrap-around
    products = np.stack([conj[0] * right[0], conj[1] * right[0], conj[2] * right[0],
                         conj[0] * right[1], conj[0] * right[2], conj[1] * right[1]])  # fmt: skip
    sums = fft.irfft(products, size, axis=-1)[..., : lag + 1]
    return sums[0], sums[1], sums[2], sums[3], sums[4], sums[5]
