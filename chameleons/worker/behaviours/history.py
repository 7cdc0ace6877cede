"""The participant's recent frames on the local clock, and the capture-clock mapping."""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import numpy.typing as npt

from chameleons.worker.frames import F32Array, FaceFrame

F64Array = npt.NDArray[np.float64]


class ClockMapper:
    """Maps a sender's capture clock onto this host's monotonic clock.

    The offset ``receive - capture`` is the clock offset plus the transport delay; its
    minimum over a sliding window is the best estimate of the offset (the least-delayed
    frame), and the window lets it follow slow drift. A jump larger than ``jump_seconds``
    (a restarted phone, another device) resets the estimate.
    """

    def __init__(self, window_seconds: float = 10.0, jump_seconds: float = 1.0) -> None:
        self.window_seconds = window_seconds
        self.jump_seconds = jump_seconds
        self._queue: deque[tuple[float, float]] = deque()  # (receive time, offset), offsets rise
        self.resets = 0

    @property
    def offset(self) -> float:
        return self._queue[0][1] if self._queue else math.nan

    def to_local(self, capture_time: float, receive_time: float) -> float:
        offset = receive_time - capture_time
        queue = self._queue
        if queue and offset - queue[0][1] > self.jump_seconds:
            queue.clear()
            self.resets += 1
        while queue and queue[-1][1] >= offset:
            queue.pop()
        queue.append((receive_time, offset))
        while queue[0][0] < receive_time - self.window_seconds:
            queue.popleft()
        return capture_time + queue[0][1]


class FrameHistory:
    """A bounded ring buffer of face vectors stamped with local capture times.

    Every sample is written twice (at ``i`` and ``i + capacity``) so the retained frames are
    always one contiguous, time-ordered slice: lookups are a single ``searchsorted``.
    """

    def __init__(self, capacity: int, width: int = FaceFrame.VECTOR_SIZE, max_gap: float = 0.5):
        if capacity < 2:
            raise ValueError("history capacity must be at least 2 frames")
        self.capacity = capacity
        self.max_gap = max_gap  # hold, rather than interpolate, across a longer dropout
        self._times: F64Array = np.zeros(2 * capacity)
        self._values: F32Array = np.zeros((2 * capacity, width), dtype=np.float32)
        self._written = 0
        self.first_time = math.nan  # first frame ever: before it the history is empty
        self.out_of_order = 0
        self.underruns = 0

    def __len__(self) -> int:
        return min(self._written, self.capacity)

    @property
    def last_time(self) -> float:
        if not self._written:
            return -math.inf
        return float(self._times[(self._written - 1) % self.capacity])

    def append(self, t: float, vector: F32Array) -> bool:
        if t <= self.last_time or not math.isfinite(t):
            self.out_of_order += 1
            return False
        i = self._written % self.capacity
        for j in (i, i + self.capacity):
            self._times[j] = t
            self._values[j] = vector
        if not self._written:
            self.first_time = t
        self._written += 1
        return True

    def window(self) -> tuple[F64Array, F32Array]:
        """The retained frames, oldest first: times and vectors (views, do not modify)."""
        count = len(self)
        start = (self._written - count) % self.capacity
        return self._times[start : start + count], self._values[start : start + count]

    def sample(self, t: float, out: F32Array) -> float:
        """Interpolate linearly at local time ``t`` into ``out``; return the time of the
        newest frame used, or NaN (``out`` untouched) before the first frame."""
        if not self._written or t < self.first_time:
            return math.nan
        times, values = self.window()
        i = int(np.searchsorted(times, t, side="right"))
        if i == 0:  # older than anything still retained
            self.underruns += 1
            out[:] = values[0]
            return float(times[0])
        if i == len(times):
            out[:] = values[-1]
            return float(times[-1])
        t0, t1 = times[i - 1], times[i]
        if t1 - t0 > self.max_gap:
            out[:] = values[i - 1]
            return float(t0)
        w = (t - t0) / (t1 - t0)
        np.subtract(values[i], values[i - 1], out=out)
        out *= np.float32(w)
        out += values[i - 1]
        return float(t1) if w > 0 else float(t0)
