"""The lag curves of a pair of streams (:func:`lag_curves`: per-lag mean |z| over windows,
then over channels) and of its pseudo-pairs, the surrogate baseline: other participants'
pairs, else segment shuffling within the interaction (:func:`segment_shuffles`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from chameleons.experiment.stats.synchrony.ccf import windowed_ccf
from chameleons.experiment.stats.synchrony.params import SyncParams
from chameleons.experiment.stats.synchrony.streams import Array, FaceStream, grid, resample

Bools = npt.NDArray[np.bool_]
MIN_SEGMENTS = 4
HEAD_PREFIX = "head_"


@dataclass(frozen=True)
class Curves:
    combined: Array
    head: Array
    face: Array
    windows: int


def lag_curves(p: Array, r: Array, channels: Sequence[str], params: SyncParams) -> Curves | None:
    """Per-lag mean |z| over windows, then over channels (all, head, face); ``p`` and ``r``
    are ``(samples, channels)`` on one grid."""
    win, inc = params.samples(params.window_s), params.samples(params.increment_s)
    lag = params.samples(params.max_lag_s)
    if p.shape[0] < win + lag:
        return None
    table = windowed_ccf(p.T, r.T, win, inc, lag)  # (channels, windows, lags)
    per_channel = nanmean(table, axis=1)  # (channels, lags)
    head = np.array([c.startswith(HEAD_PREFIX) for c in channels])
    return Curves(nanmean(per_channel, 0), nanmean(per_channel[head], 0),
                  nanmean(per_channel[~head], 0), table.shape[1])  # fmt: skip


def segment_shuffles(
    p: Array, r: Array, params: SyncParams, count: int
) -> list[tuple[Array, Array]]:
    """``count`` pseudo-pairs from one interaction: both streams cut into segments
    (:func:`segment_samples`; the remainder dropped), each shuffled, never two segments of
    the same time side by side. Empty when fewer than two segments fit."""
    seg = segment_samples(p.shape[0], params)
    n = p.shape[0] // seg
    if n < MIN_SEGMENTS:
        return []
    rng = np.random.default_rng([params.seed, 1])
    pairs = []
    for _ in range(count):
        first = rng.permutation(n)
        second = rng.permutation(n)
        while np.any(first == second):  # a derangement relative to the first
            second = rng.permutation(n)
        pi = (first[:, None] * seg + np.arange(seg)).ravel()
        ri = (second[:, None] * seg + np.arange(seg)).ravel()
        pairs.append((p[pi], r[ri]))
    return pairs


def segment_samples(samples: int, params: SyncParams) -> int:
    """The segment length of the within-interaction fallback: ``segment_s``, shortened in a
    short interaction so that ``MIN_SEGMENTS`` fit, but never below the lag range (a
    shuffled segment then still holds the largest lag). Fewer segments would give only a
    handful of distinct shuffles, so then there is no within-interaction baseline."""
    seg = params.samples(params.segment_s)
    if samples // seg < MIN_SEGMENTS:
        seg = max(params.samples(params.max_lag_s), samples // MIN_SEGMENTS, 1)
    return seg


def surrogate_curves(
    p: Array, r: Array, channels: list[str],
    surrogates: Sequence[tuple[FaceStream, FaceStream]], params: SyncParams,
) -> tuple[list[Array], str, list[int]]:  # fmt: skip
    """The pseudo-pairs' lag curves, their kind, and which of ``surrogates`` gave one."""
    curves, used = [], []
    grids: dict[int, Array] = {}  # one stream is in many pairs: resample it once

    def own(stream: FaceStream) -> Array:
        if id(stream) not in grids:
            grids[id(stream)] = own_grid(stream, channels, params)
        return grids[id(stream)]

    for index, (other_p, other_r) in enumerate(surrogates[: params.surrogates]):
        a, b = own(other_p), own(other_r)
        n = min(a.shape[0], b.shape[0])
        usable = moving(a[:n], params) & moving(b[:n], params)
        if not usable.any():
            continue
        names = [c for c, u in zip(channels, usable, strict=True) if u]
        found = lag_curves(a[:n][:, usable], b[:n][:, usable], names, params)
        if found is not None and np.isfinite(found.combined).any():
            curves.append(found.combined)
            used.append(index)
    if len(curves) >= params.min_between:
        return curves, "between", used
    shuffled = []
    for a, b in segment_shuffles(p, r, params, params.surrogates):
        found = lag_curves(a, b, channels, params)
        if found is not None and np.isfinite(found.combined).any():
            shuffled.append(found.combined)
    return (shuffled, "segments", []) if shuffled else ([], "none", [])


def own_grid(stream: FaceStream, channels: list[str], params: SyncParams) -> Array:
    """A stream on a grid from its own first frame after the settling time (pseudo-pairs
    are aligned by start)."""
    chosen = stream.select(channels)
    if chosen.empty or chosen.end <= chosen.start + params.settle_s:
        return np.empty((0, len(channels)))
    times = grid(chosen.start + params.settle_s, chosen.end, params.rate_hz)
    return resample(chosen, times, params.max_gap_s)


def moving(values: Array, params: SyncParams) -> Bools:
    finite = np.isfinite(values)
    counts = finite.sum(0)
    safe = np.where(finite, values, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = safe.sum(0) / counts
        var = np.where(finite, np.square(safe - mean), 0.0).sum(0) / counts
    return np.asarray((counts >= 3) & (np.sqrt(var) > params.min_motion))


def nanmean(values: Array, axis: int) -> Array:
    """NaN-ignoring mean without the empty-slice warning (an all-missing slice: NaN)."""
    finite = np.isfinite(values)
    counts = finite.sum(axis)
    total = np.where(finite, values, 0.0).sum(axis)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(np.where(counts > 0, total / counts, np.nan))
