"""Synchrony of a participant's and a robot's face in one interaction, with its surrogate
baseline: the robot following the participant (fidelity: did the manipulation run?) and
the participant following the robot (mimicry, an outcome).

Method (docs/science.md, "Synchrony"): both streams on a common grid (:mod:`.streams`);
per channel the windowed lagged cross-correlation of rMEA's ``MEAccf`` (:mod:`.ccf`:
|Fisher z| per window and lag); per channel the mean over windows (rMEA's per-lag
aggregate); the **lag curve** is the mean over channels (head yaw, pitch, roll and the
face's blendshapes that move in both streams). On the curve the lag axis is the robot's
delay: positive lags, the robot later than the participant. ``sync`` is the peak over the
positive lags, ``mimicry`` over the negative lags (reported as the participant's delay, a
positive number of seconds); each peak's lag is refined by a parabola through it and its
neighbours, its ``r`` is ``tanh`` of the mean |z| there.

The **surrogate baseline** (pseudo-synchrony) is the same measure on pairs that never met:
this participant with other participants' robots and other participants with this robot
(rMEA's ``shuffle``, Ramseyer & Tschacher 2010), each stream from its own start, cut to
the shorter. Without enough of them (the first sessions of a study) it falls back to
segment shuffling within the interaction (rMEA's ``shuffle_segments``), with no segment
of the two streams left side by side as recorded (Moulder et al. 2018), and says so.
``mimicry_r`` is surrogate-corrected: ``tanh(z - mean surrogate z)`` of the peaks.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from chameleons.experiment.stats.synchrony.ccf import windowed_ccf
from chameleons.experiment.stats.synchrony.streams import (
    Array,
    FaceStream,
    grid,
    resample,
    usable_share,
    without_speech,
)

Ints = npt.NDArray[np.int64]
Bools = npt.NDArray[np.bool_]
METHOD_VERSION = 1
MIN_SEGMENTS = 4
MOUTH_PREFIXES = ("mouth", "jaw")
HEAD_PREFIX = "head_"


@dataclass(frozen=True)
class SyncParams:
    """How synchrony is computed (stored with every result: a number traces back here)."""

    rate_hz: int = 25  # grid rate: 0.04 s lag steps (rMEA's 25 fps), refined by a parabola
    window_s: float = 30.0  # rMEA winSec
    increment_s: float = 15.0  # rMEA incSec: half-overlapping windows
    max_lag_s: float = 6.0  # rMEA lagSec: +-6 s covers the copy's 4 s delay with room
    max_gap_s: float = 0.25  # frames further apart than this: a capture gap (missing)
    speech_margin_s: float = 0.5  # mouth/jaw of the robot missing this long around speech
    min_motion: float = 1e-6  # a channel whose SD is below this does not move
    surrogates: int = 40  # pseudo-pairs per interaction (between, else segment shuffles)
    min_between: int = 10  # fewer usable between-participant pairs: segment shuffling
    segment_s: float = 30.0  # segment length of the within-interaction fallback
    band: float = 0.95  # the surrogate band: this quantile of the surrogate peaks
    lag_tolerance_s: float = 0.2  # a copy's measured lag this far off its delay: flagged
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("window_s", "increment_s", "max_lag_s", "segment_s"):
            samples = getattr(self, name) * self.rate_hz
            if samples < 1 or abs(samples - round(samples)) > 1e-9:
                raise ValueError(f"{name} = {getattr(self, name)} s is not a whole number of "
                                 f"samples at {self.rate_hz} Hz")  # fmt: skip

    def samples(self, seconds: float) -> int:
        return round(seconds * self.rate_hz)

    @property
    def minimum_s(self) -> float:
        """The shortest overlap of the two streams that gives one window."""
        return self.window_s + self.max_lag_s

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "method_version": METHOD_VERSION}


@dataclass
class Peak:
    lag_s: float
    z: float

    @property
    def r(self) -> float:
        return math.tanh(self.z)


@dataclass
class SynchronyResult:
    """One interaction's synchrony; ``reason`` says why values are missing (else None)."""

    params: dict[str, Any]
    reason: str | None = None
    detail: str = ""
    lags_s: list[float] = field(default_factory=list)
    curve: list[float | None] = field(default_factory=list)  # mean |z| per lag
    head_curve: list[float | None] = field(default_factory=list)
    face_curve: list[float | None] = field(default_factory=list)
    surrogate_mean: list[float | None] = field(default_factory=list)
    surrogate_high: list[float | None] = field(default_factory=list)  # per-lag band
    sync_lag_s: float | None = None
    sync_r: float | None = None
    sync_band_r: float | None = None  # the band quantile of the surrogate sync peaks
    sync_p: float | None = None
    mimicry_lag_s: float | None = None
    mimicry_raw_r: float | None = None
    mimicry_r: float | None = None  # surrogate-corrected
    mimicry_surrogate_r: float | None = None  # mean of the surrogate mimicry peaks
    mimicry_p: float | None = None
    mimicry_es: float | None = None  # (z - surrogate mean) / surrogate SD (SUSY's ES)
    check: str | None = None  # copy interactions: "ok" or "failed"
    check_reason: str = ""
    usable_share: float = 0.0
    duration_s: float = 0.0
    channels: list[str] = field(default_factory=list)
    windows: int = 0
    surrogate_kind: str = "none"  # between | segments | none
    surrogate_count: int = 0
    surrogates_used: list[int] = field(default_factory=list)  # indices of the pairs given
    segment_s: float | None = None  # the fallback's segment length, when it was used

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class Curves:
    combined: Array
    head: Array
    face: Array
    windows: int


def mask_speech(robot: FaceStream, speech: Sequence[tuple[float, float]],
                params: SyncParams) -> FaceStream:  # fmt: skip
    """The robot's frames with mouth and jaw missing while it speaks (lip-sync)."""
    mouth = [c for c in robot.channels if c.startswith(MOUTH_PREFIXES)]
    return without_speech(robot, speech, mouth, params.speech_margin_s)


def measure_synchrony(
    participant: FaceStream,
    robot: FaceStream,
    surrogates: Sequence[tuple[FaceStream, FaceStream]],
    params: SyncParams,
    copy_delay_s: float | None = None,
) -> SynchronyResult:
    """Synchrony of one interaction (``robot`` already without its speech: see
    :func:`mask_speech`); ``surrogates``: (participant, robot) pairs that never met;
    ``copy_delay_s``: the configured delay when the robot ran ``copy`` (then checked)."""
    result = SynchronyResult(params.to_dict())
    lags = np.arange(-params.samples(params.max_lag_s), params.samples(params.max_lag_s) + 1,
                     dtype=np.int64)  # fmt: skip
    result.lags_s = [round(float(k) / params.rate_hz, 6) for k in lags]
    if participant.empty or robot.empty:
        which = "participant" if participant.empty else "robot"
        return _missing(result, "no_frames", f"The {which}'s recording has no frames.")
    result.usable_share = usable_share(participant, robot, params.rate_hz, params.max_gap_s)
    start, end = max(participant.start, robot.start), min(participant.end, robot.end)
    result.duration_s = max(0.0, end - start)
    if result.duration_s < params.minimum_s:
        return _missing(result, "too_short", (
            f"The two recordings overlap for {result.duration_s:.1f} s; synchrony needs at "
            f"least {params.minimum_s:g} s (a {params.window_s:g} s window and a "
            f"{params.max_lag_s:g} s lag)."))  # fmt: skip
    times = grid(start, end, params.rate_hz)
    p = resample(participant, times, params.max_gap_s)
    r = resample(robot, times, params.max_gap_s)
    names = [c for c in participant.channels if c in set(robot.channels)]
    p = p[:, [participant.channels.index(c) for c in names]]
    r = r[:, [robot.channels.index(c) for c in names]]
    moving_p, moving_r = _moving(p, params), _moving(r, params)
    used = moving_p & moving_r
    if not used.any():
        if not moving_r.any():
            return _missing(result, "robot_still", "The robot's head and face did not move: "
                            "there is no synchrony to measure (a still robot).")  # fmt: skip
        if not moving_p.any():
            return _missing(
                result, "participant_still", "The participant's recorded face did not move."
            )
        return _missing(
            result,
            "no_common_channels",
            "No channel moved in both the participant's and the robot's face.",
        )
    channels = [n for n, u in zip(names, used, strict=True) if u]
    p, r = p[:, used], r[:, used]
    curves = lag_curves(p, r, channels, params)
    if curves is None or not np.isfinite(curves.combined).any():
        return _missing(result, "gaps", "Too much of the recordings is missing (capture gaps) "
                        "for a single usable window.")  # fmt: skip
    result.channels, result.windows = channels, curves.windows
    result.curve, result.head_curve = _listed(curves.combined), _listed(curves.head)
    result.face_curve = _listed(curves.face)
    pseudo, kind, used_pairs = _surrogate_curves(p, r, channels, surrogates, params)
    result.surrogate_kind, result.surrogate_count = kind, len(pseudo)
    result.surrogates_used = used_pairs
    if kind == "segments":
        result.segment_s = segment_samples(p.shape[0], params) / params.rate_hz
    _peaks(result, curves.combined, lags, pseudo, params)
    if copy_delay_s is not None:
        _check_copy(result, copy_delay_s, params)
    if result.mimicry_r is None or result.sync_band_r is None:
        result.detail = (
            "No surrogate baseline: too few other participants' recordings, and too short "
            f"for {MIN_SEGMENTS} shuffled segments of at least {params.max_lag_s:g} s; "
            "mimicry_r and the surrogate band are empty (chameleons synchrony computes them "
            "again once more participants are recorded)."
            if not pseudo else
            "The pseudo-pairs gave no comparable peak (their faces hardly moved): mimicry_r "
            "or the surrogate band is empty."
        )  # fmt: skip
    return result


def lag_curves(p: Array, r: Array, channels: Sequence[str], params: SyncParams) -> Curves | None:
    """Per-lag mean |z| over windows, then over channels (all, head, face); ``p`` and ``r``
    are ``(samples, channels)`` on one grid."""
    win, inc = params.samples(params.window_s), params.samples(params.increment_s)
    lag = params.samples(params.max_lag_s)
    if p.shape[0] < win + lag:
        return None
    table = windowed_ccf(p.T, r.T, win, inc, lag)  # (channels, windows, lags)
    per_channel = _nanmean(table, axis=1)  # (channels, lags)
    head = np.array([c.startswith(HEAD_PREFIX) for c in channels])
    return Curves(_nanmean(per_channel, 0), _nanmean(per_channel[head], 0),
                  _nanmean(per_channel[~head], 0), table.shape[1])  # fmt: skip


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


def _surrogate_curves(
    p: Array, r: Array, channels: list[str],
    surrogates: Sequence[tuple[FaceStream, FaceStream]], params: SyncParams,
) -> tuple[list[Array], str, list[int]]:  # fmt: skip
    """The pseudo-pairs' lag curves, their kind, and which of ``surrogates`` gave one."""
    curves, used = [], []
    grids: dict[int, Array] = {}  # one stream is in many pairs: resample it once

    def own(stream: FaceStream) -> Array:
        if id(stream) not in grids:
            grids[id(stream)] = _own_grid(stream, channels, params)
        return grids[id(stream)]

    for index, (other_p, other_r) in enumerate(surrogates[: params.surrogates]):
        a, b = own(other_p), own(other_r)
        n = min(a.shape[0], b.shape[0])
        usable = _moving(a[:n], params) & _moving(b[:n], params)
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


def _own_grid(stream: FaceStream, channels: list[str], params: SyncParams) -> Array:
    """A stream on a grid from its own first frame (pseudo-pairs are aligned by start)."""
    chosen = stream.select(channels)
    if chosen.empty:
        return np.empty((0, len(channels)))
    return resample(chosen, grid(chosen.start, chosen.end, params.rate_hz), params.max_gap_s)


def _peaks(result: SynchronyResult, curve: Array, lags: Ints, pseudo: list[Array],
           params: SyncParams) -> None:  # fmt: skip
    rate = params.rate_hz
    follow, lead = lags > 0, lags < 0
    sync = _peak(curve, lags, follow, rate)
    mimicry = _peak(curve, lags, lead, rate)
    if pseudo:
        table = np.vstack(pseudo)
        result.surrogate_mean = _listed(_nanmean(table, 0))
        result.surrogate_high = _listed(_nanquantile(table, params.band))
    sync_null = [p.z for c in pseudo if (p := _peak(c, lags, follow, rate)) is not None]
    mimicry_null = [p.z for c in pseudo if (p := _peak(c, lags, lead, rate)) is not None]
    if sync is not None:
        result.sync_lag_s, result.sync_r = round(sync.lag_s, 4), sync.r
        if sync_null:
            result.sync_band_r = math.tanh(float(np.quantile(sync_null, params.band)))
            result.sync_p = _p_value(sync.z, sync_null)
    if mimicry is not None:
        result.mimicry_lag_s, result.mimicry_raw_r = round(-mimicry.lag_s, 4), mimicry.r
        if mimicry_null:
            mean = float(np.mean(mimicry_null))
            result.mimicry_r = math.tanh(mimicry.z - mean)
            result.mimicry_surrogate_r = math.tanh(mean)
            result.mimicry_p = _p_value(mimicry.z, mimicry_null)
            sd = float(np.std(mimicry_null, ddof=1)) if len(mimicry_null) > 1 else 0.0
            result.mimicry_es = (mimicry.z - mean) / sd if sd > 0 else None


def _peak(curve: Array, lags: Ints, side: Bools, rate: int) -> Peak | None:
    values = np.where(side & np.isfinite(curve), curve, -np.inf)
    best = int(np.argmax(values))
    if not np.isfinite(values[best]):
        return None
    position = float(lags[best])
    inner = 0 < best < len(values) - 1
    if inner and side[best - 1 : best + 2].all() and np.isfinite(values[best - 1 : best + 2]).all():
        left, mid, right = values[best - 1], values[best], values[best + 1]
        bend = left - 2 * mid + right
        if bend < 0:
            position += 0.5 * (left - right) / bend
    return Peak(position / rate, float(values[best]))


def _check_copy(result: SynchronyResult, delay: float, params: SyncParams) -> None:
    """A copy interaction: its robot should follow at the configured delay, above chance."""
    problems = []
    if result.sync_lag_s is None or result.sync_r is None:
        result.check, result.check_reason = "failed", "No synchrony peak could be measured."
        return
    if abs(result.sync_lag_s - delay) > params.lag_tolerance_s:
        problems.append(f"the robot followed at {result.sync_lag_s:.2f} s, not at the "
                        f"configured {delay:g} s")  # fmt: skip
    if result.sync_band_r is not None and result.sync_r <= result.sync_band_r:
        problems.append(f"its correlation {result.sync_r:.2f} is not above the surrogate "
                        f"band ({result.sync_band_r:.2f})")  # fmt: skip
    result.check = "failed" if problems else "ok"
    note = "" if result.sync_band_r is not None else " (no surrogate band to compare with)"
    result.check_reason = ("; ".join(problems) + "." if problems else
                           f"The robot followed at {result.sync_lag_s:.2f} s{note}.")  # fmt: skip
    result.check_reason = result.check_reason[0].upper() + result.check_reason[1:]


def _p_value(observed: float, null: Sequence[float]) -> float:
    """Share of pseudo-pairs at least as synchronous, counting the observed pair."""
    return (1 + sum(1 for z in null if z >= observed)) / (1 + len(null))


def _moving(values: Array, params: SyncParams) -> Bools:
    finite = np.isfinite(values)
    counts = finite.sum(0)
    safe = np.where(finite, values, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = safe.sum(0) / counts
        var = np.where(finite, np.square(safe - mean), 0.0).sum(0) / counts
    return np.asarray((counts >= 3) & (np.sqrt(var) > params.min_motion))


def _nanmean(values: Array, axis: int) -> Array:
    """NaN-ignoring mean without the empty-slice warning (an all-missing slice: NaN)."""
    finite = np.isfinite(values)
    counts = finite.sum(axis)
    total = np.where(finite, values, 0.0).sum(axis)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(np.where(counts > 0, total / counts, np.nan))


def _nanquantile(values: Array, q: float) -> Array:
    out = np.full(values.shape[1], np.nan)
    for column in range(values.shape[1]):
        finite = values[:, column][np.isfinite(values[:, column])]
        if finite.size:
            out[column] = float(np.quantile(finite, q))
    return out


def _listed(values: Array) -> list[float | None]:
    return [round(float(v), 6) if np.isfinite(v) else None for v in values]


def _missing(result: SynchronyResult, reason: str, detail: str) -> SynchronyResult:
    result.reason, result.detail = reason, detail
    return result
