"""Face streams onto a common time grid: resampling, capture gaps, and the robot's speech.

A stream is what a recording holds: frame times (seconds, one clock) and per-frame channel
values (NaN where the source cannot measure a channel). :func:`resample` puts a stream on
a regular grid by linear interpolation between the frames around each grid point; a grid
point whose surrounding frames are further apart than ``max_gap`` seconds (a capture gap:
the phone stopped sending, the tracker lost the face), or that lies outside the recording,
is missing (NaN), as is one next to a missing value. Missing samples are then handled as
rMEA does (:mod:`.ccf`): complete pairs only, and a window more than half missing is not
used.

Lip-sync is not mimicry: while the robot speaks, its mouth and jaw channels follow the
prompt's lip-sync curves, not the behaviour. :func:`without_speech` marks those channels
missing in the robot's frames during each speech interval (widened by a margin for the
renderer's blend in and out), before resampling.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class FaceStream:
    """Frames of one face: ``times`` (seconds, increasing), ``values`` ``(frames,
    channels)``, ``channels`` their names."""

    times: Array
    values: Array
    channels: tuple[str, ...]

    def __post_init__(self) -> None:
        if self.values.ndim != 2 or self.values.shape != (len(self.times), len(self.channels)):
            raise ValueError(
                f"{len(self.times)} frame times, {len(self.channels)} channels and values of "
                f"shape {self.values.shape} do not fit together"
            )

    @classmethod
    def of(cls, times: npt.ArrayLike, values: npt.ArrayLike, channels: Sequence[str]
           ) -> FaceStream:  # fmt: skip
        """Frames in any order (sorted here; of frames with the same time the last wins)."""
        t = np.asarray(times, dtype=np.float64)
        v = np.asarray(values, dtype=np.float64).reshape(len(t), len(channels))
        keep = np.isfinite(t)
        t, v = t[keep], v[keep]
        order = np.argsort(t, kind="stable")
        t, v = t[order], v[order]
        if len(t):
            last = np.append(t[1:] != t[:-1], True)
            t, v = t[last], v[last]
        return cls(t, v, tuple(channels))

    @property
    def empty(self) -> bool:
        return len(self.times) == 0

    @property
    def start(self) -> float:
        return float(self.times[0])

    @property
    def end(self) -> float:
        return float(self.times[-1])

    def select(self, channels: Sequence[str]) -> FaceStream:
        """The named channels, in that order (a channel the stream lacks: all missing)."""
        index = {name: i for i, name in enumerate(self.channels)}
        values = np.full((len(self.times), len(channels)), np.nan)
        for column, name in enumerate(channels):
            if name in index:
                values[:, column] = self.values[:, index[name]]
        return FaceStream(self.times, values, tuple(channels))


def without_speech(
    stream: FaceStream, speech: Sequence[tuple[float, float]], mouth: Sequence[str],
    margin: float,
) -> FaceStream:  # fmt: skip
    """``stream`` with its ``mouth`` channels missing during each ``(start, end)`` of
    ``speech`` (same clock as the frames), widened by ``margin`` seconds on both sides."""
    columns = np.array([i for i, name in enumerate(stream.channels) if name in set(mouth)],
                       dtype=np.intp)  # fmt: skip
    if not speech or not columns.size or stream.empty:
        return stream
    speaking = np.zeros(len(stream.times), dtype=bool)
    for start, end in speech:
        speaking |= (stream.times >= start - margin) & (stream.times <= end + margin)
    values = stream.values.copy()
    values[np.ix_(speaking, columns)] = np.nan
    return FaceStream(stream.times, values, stream.channels)


def grid(start: float, end: float, rate: float) -> Array:
    """Grid times from ``start`` to at most ``end``, ``rate`` per second."""
    count = int(np.floor((end - start) * rate + 1e-9)) + 1 if end >= start else 0
    return start + np.arange(count) / rate


def resample(stream: FaceStream, times: Array, max_gap: float) -> Array:
    """The stream's values at ``times`` ``(len(times), channels)``: linear interpolation
    between the two frames around each time; NaN outside the recording, across a gap
    longer than ``max_gap`` seconds, or next to a missing value."""
    out = np.full((len(times), len(stream.channels)), np.nan)
    if len(stream.times) == 0 or len(times) == 0:
        return out
    t = stream.times
    right = np.searchsorted(t, times, side="left")  # first frame at or after each time
    inside = (times >= t[0]) & (times <= t[-1])
    exact = inside & (right < len(t)) & (t[np.minimum(right, len(t) - 1)] == times)
    between = inside & ~exact
    if exact.any():
        out[exact] = stream.values[right[exact]]
    if between.any():
        hi = right[between]
        lo = hi - 1
        span = t[hi] - t[lo]
        weight = ((times[between] - t[lo]) / span)[:, None]
        values = stream.values[lo] * (1.0 - weight) + stream.values[hi] * weight
        values[span > max_gap] = np.nan
        out[between] = values
    return out


def usable_share(participant: FaceStream, robot: FaceStream, rate: float,
                 max_gap: float) -> float:  # fmt: skip
    """The share of the time from the first frame of either stream to the last of either
    in which both have frames (no gap longer than ``max_gap``); 0 without frames."""
    if participant.empty or robot.empty:
        return 0.0
    times = grid(min(participant.start, robot.start), max(participant.end, robot.end), rate)
    if len(times) == 0:
        return 0.0
    present = _present(participant, times, max_gap) & _present(robot, times, max_gap)
    return float(present.mean())


def _present(stream: FaceStream, times: Array, max_gap: float) -> npt.NDArray[np.bool_]:
    """Whether a frame of ``stream`` lies within a gap bound around each time."""
    t = stream.times
    right = np.clip(np.searchsorted(t, times, side="left"), 0, len(t) - 1)
    left = np.clip(right - 1, 0, len(t) - 1)
    inside = (times >= t[0]) & (times <= t[-1])
    close = (t[right] - t[left] <= max_gap) | (t[right] == times)
    return np.asarray(inside & close)
