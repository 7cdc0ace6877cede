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

from chameleons.experiment.stats.synchrony.curves import (
    MIN_SEGMENTS,
    Curves,
    lag_curves,
    moving,
    nanmean,
    segment_samples,
    segment_shuffles,
    surrogate_curves,
)
from chameleons.experiment.stats.synchrony.params import METHOD_VERSION, SyncParams
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
MOUTH_PREFIXES = ("mouth", "jaw")

__all__ = [
    "METHOD_VERSION",
    "MIN_SEGMENTS",
    "Curves",
    "Peak",
    "SyncParams",
    "SynchronyResult",
    "lag_curves",
    "mask_speech",
    "measure_synchrony",
    "segment_samples",
    "segment_shuffles",
]


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
            f"{params.max_lag_s:g} s lag after the first {params.settle_s:g} s, which is "
            "left out: the robot's switch from the condition before)."))  # fmt: skip
    times = grid(start + params.settle_s, end, params.rate_hz)
    p = resample(participant, times, params.max_gap_s)
    r = resample(robot, times, params.max_gap_s)
    names = [c for c in participant.channels if c in set(robot.channels)]
    p = p[:, [participant.channels.index(c) for c in names]]
    r = r[:, [robot.channels.index(c) for c in names]]
    moving_p, moving_r = moving(p, params), moving(r, params)
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
    pseudo, kind, used_pairs = surrogate_curves(p, r, channels, surrogates, params)
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


def _peaks(result: SynchronyResult, curve: Array, lags: Ints, pseudo: list[Array],
           params: SyncParams) -> None:  # fmt: skip
    rate = params.rate_hz
    follow, lead = lags > 0, lags < 0
    sync = _peak(curve, lags, follow, rate)
    mimicry = _peak(curve, lags, lead, rate)
    if pseudo:
        table = np.vstack(pseudo)
        result.surrogate_mean = _listed(nanmean(table, 0))
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
