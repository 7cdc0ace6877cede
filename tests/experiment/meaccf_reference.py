"""A second, independent implementation of rMEA's ``MEAccf`` for the tests: a direct,
loop-by-loop transcription of ``MEAccf.MEA`` (rMEA 1.2.x, ``R/rMEA_ccf.R``; Kleinbub &
Ramseyer 2020), one window and one lag at a time, with R's 1-based ranges kept in the
comments and Pearson's correlation written out as R's ``cor(x, y, use = "complete.obs")``
computes it (two-pass: means first, then the centred sums).

It keeps rMEA's own rules exactly, including ``sum(x != y, na.rm = TRUE) < 2 -> NA``; the
production code (:mod:`chameleons.experiment.stats.synchrony.ccf`) replaces that rule by
"fewer than three complete pairs, or no variation", which is the same on recorded data
(where two series never agree to the last bit in all but one sample).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]


def fisher_r2z(r: float) -> float:
    """rMEA's ``fisher.r2z``: atanh, bounded to +-10."""
    if math.isnan(r):
        return math.nan
    if r >= 1.0:
        return 10.0
    if r <= -1.0:
        return -10.0
    return max(-10.0, min(10.0, 0.5 * (math.log(1 + r) - math.log(1 - r))))


def r_cor_complete(x: list[float], y: list[float]) -> float:
    """R's ``cor(x, y, use = "complete.obs")`` for two vectors: NA for a zero SD."""
    pairs = [(a, b) for a, b in zip(x, y, strict=True) if not (math.isnan(a) or math.isnan(b))]
    n = len(pairs)
    if n < 2:
        return math.nan
    mean_x = sum(a for a, _ in pairs) / n
    mean_y = sum(b for _, b in pairs) / n
    sxy = sum((a - mean_x) * (b - mean_y) for a, b in pairs)
    sxx = sum((a - mean_x) ** 2 for a, _ in pairs)
    syy = sum((b - mean_y) ** 2 for _, b in pairs)
    if sxx == 0.0 or syy == 0.0:
        return math.nan  # R: "the standard deviation is zero"
    return sxy / math.sqrt(sxx * syy)


def meaccf(
    s1: Array, s2: Array, samp_rate: int, lag_sec: float, win_sec: float, inc_sec: float,
    r2z: bool = True, absolute: bool = True,
) -> Array:  # fmt: skip
    """The ``ccf`` table of ``MEAccf``: one row per window, one column per lag (-lag..lag)."""
    win = round(win_sec * samp_rate)
    lag_samp = round(lag_sec * samp_rate)
    inc = round(inc_sec * samp_rate)
    ran = list(range(-lag_samp, lag_samp + 1))
    n_win = math.ceil((len(s1) - win - lag_samp + 1) / inc)
    table = np.full((max(n_win, 0), len(ran)), np.nan)
    for i_win in range(max(n_win, 0)):
        # R: ab = (iWin*inc + 1):(iWin*inc + win + lagSamp)
        first = i_win * inc
        x_win = [float(v) for v in s1[first : first + win + lag_samp]]
        y_win = [float(v) for v in s2[first : first + win + lag_samp]]
        na_x = sum(math.isnan(v) for v in x_win)
        na_y = sum(math.isnan(v) for v in y_win)
        if max(na_x, na_y) > len(x_win) / 2:
            continue  # too many NA: NA at every lag
        for column, i_lag in enumerate(ran):
            big_lag = abs(i_lag)
            x_range = list(range(0, win))  # R: 1:(win)
            y_range = list(range(big_lag, win + big_lag))  # R: (LAG+1):(win+LAG)
            if i_lag < 0:
                x_range, y_range = y_range, x_range
            x = [x_win[k] for k in x_range]
            y = [y_win[k] for k in y_range]
            differing = sum(1 for a, b in zip(x, y, strict=True)
                            if not (math.isnan(a) or math.isnan(b)) and a != b)  # fmt: skip
            value = math.nan if differing < 2 else r_cor_complete(x, y)
            if r2z:
                value = fisher_r2z(value)
            if absolute and not math.isnan(value):
                value = abs(value)
            table[i_win, column] = value
    return table
