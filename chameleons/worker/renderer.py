"""The renderer: mixes the agent face with lip-sync and drives the robot at a fixed rate.

One side (:meth:`RenderCore.push_keyframe`, any thread) stores the behaviour stage's agent
keyframes; the tick side (:class:`RenderLoop`, one thread, 125 Hz by default, deadline
based) renders tick ``k`` for its scheduled time ``k / rate`` on the monotonic clock:
interpolates the keyframes at that time, lets lip-sync own the mouth and jaw channels while
the robot speaks, low-passes the head rotation with an FIR filter designed once, sends the
head pose every tick and the face parameters at the face rate. Everything a tick touches is
preallocated.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.signal import firwin

from chameleons.worker.behaviours.base import HEAD_SLICE, VECTOR_SIZE
from chameleons.worker.behaviours.history import FrameHistory
from chameleons.worker.drivers.base import Driver
from chameleons.worker.frames import MOUTH_JAW_INDICES, N_BLENDSHAPES, F32Array
from chameleons.worker.lipsync import LipSync

F64Array = npt.NDArray[np.float64]
# Mouth and jaw are one contiguous block of the canonical order: a slice, no fancy indexing.
MOUTH_JAW = slice(MOUTH_JAW_INDICES[0], MOUTH_JAW_INDICES[-1] + 1)
KEYFRAME_WIDTH = VECTOR_SIZE + 2  # the face, then (t - input time) and the intended lag
assert list(range(MOUTH_JAW.start, MOUTH_JAW.stop)) == list(MOUTH_JAW_INDICES)


@dataclass(frozen=True, slots=True)
class RenderConfig:
    tick_rate: float = 125.0
    face_rate: float = 25.0
    fir_taps: int = 15
    fir_cutoff_hz: float = 6.0
    lipsync_fade: float = 0.06  # seconds to hand the mouth to lip-sync and back

    def __post_init__(self) -> None:
        if not 0 < self.face_rate <= self.tick_rate:
            raise ValueError("face rate must be positive and at most the tick rate")
        if self.fir_taps < 1 or not 0 < self.fir_cutoff_hz < self.tick_rate / 2:
            raise ValueError("FIR needs >= 1 tap and a cutoff below half the tick rate")


class HeadFilter:
    """Linear-phase FIR low-pass on yaw/pitch/roll, designed once with ``firwin``."""

    def __init__(self, taps: int, cutoff_hz: float, rate: float) -> None:
        self.taps: F64Array = (
            np.ones(1) if taps == 1 else np.asarray(firwin(taps, cutoff_hz, fs=rate))
        )
        self.rate = rate
        self._n = len(self.taps)
        self._ring: F64Array = np.zeros((2 * self._n, 3))  # doubled: one contiguous window
        self._pos = 0
        self._primed = False
        self.output: F64Array = np.zeros(3)

    @property
    def group_delay(self) -> float:
        """Seconds by which the filter delays the head: (taps - 1) / 2 / rate."""
        return (self._n - 1) / 2 / self.rate

    def push(self, head: F32Array) -> F64Array:
        if not self._primed:  # start from the first pose, not from a ramp out of zero
            self._ring[:] = head
            self._primed = True
        n, pos = self._n, self._pos
        self._ring[pos] = head
        self._ring[pos + n] = head
        self._pos = (pos + 1) % n
        np.dot(self.taps, self._ring[self._pos : self._pos + n], out=self.output)
        return self.output


class LipsyncTrack:
    """The current prompt's curves on the audio clock: pending until the driver reports
    that the audio started, then sampled at ``tick_time - start``."""

    def __init__(self, fade: float) -> None:
        self.fade = max(fade, 1e-6)
        self.curve: LipSync | None = None
        self.prompt_id: str | None = None
        self.start = math.nan
        self.end = math.inf
        self._cursor = 0
        self._mouth = np.zeros(len(MOUTH_JAW_INDICES), dtype=np.float32)

    @property
    def active(self) -> bool:
        return not math.isnan(self.start)

    def load(self, prompt_id: str, curve: LipSync | None) -> None:
        self.curve, self.prompt_id = curve, prompt_id
        self.start, self.end, self._cursor = math.nan, math.inf, 0

    def begin(self, t: float) -> None:
        self.start, self.end, self._cursor = t, math.inf, 0

    def finish(self, t: float) -> None:
        if self.active:
            self.end = min(self.end, t)

    def curve_end(self) -> float:
        return self.start + (self.curve.duration if self.curve is not None else 0.0)

    def apply(self, t: float, agent: F32Array) -> None:
        if not self.active or t < self.start:
            return
        if t >= self.end + self.fade:
            self.start = math.nan  # faded out: the behaviour owns the mouth again
            return
        curve = self.curve
        weight = min(1.0, (t - self.start) / self.fade, 1.0 - (t - self.end) / self.fade)
        if curve is None or weight <= 0.0:
            return
        u, times = t - self.start, curve.times
        last = len(times) - 1
        while self._cursor < last and times[self._cursor + 1] <= u:
            self._cursor += 1
        i = self._cursor
        mouth = self._mouth
        if i >= last or u <= times[i]:
            mouth[:] = curve.values[i]
        else:
            w = np.float32((u - times[i]) / (times[i + 1] - times[i]))
            np.subtract(curve.values[i + 1], curve.values[i], out=mouth)
            mouth *= w
            mouth += curve.values[i]
        block = agent[MOUTH_JAW]
        block *= np.float32(1.0 - weight)
        mouth *= np.float32(weight)
        block += mouth


class RenderCore:
    """Everything a tick does, without the timing (tests drive it with fake times)."""

    def __init__(self, driver: Driver, config: RenderConfig | None = None) -> None:
        self.config = config or RenderConfig()
        self.driver = driver
        self.filter = HeadFilter(self.config.fir_taps, self.config.fir_cutoff_hz,
                                 self.config.tick_rate)  # fmt: skip
        self.lipsync = LipsyncTrack(self.config.lipsync_fade)
        # Column 61 holds (keyframe time - input time), column 62 the behaviour's intended
        # lag (copy: its delay): both small, so float32 keeps them exact.
        self._keyframes = FrameHistory(32, width=KEYFRAME_WIDTH, max_gap=0.25)
        self._lock = threading.Lock()
        self._sample = np.zeros(KEYFRAME_WIDTH, dtype=np.float32)
        self.agent = self._sample[:VECTOR_SIZE]
        self.lag = 0.0  # the behaviour's intended lag at the last tick (seconds)
        self._face_step = self.config.face_rate / self.config.tick_rate
        self._face_phase = 1.0 - self._face_step  # the first tick sends the face
        self.keyframes_in = 0
        self.keyframe_resets = 0
        self.underruns = 0  # ticks past the newest keyframe (the behaviour stage fell behind)
        self._last_tick: float | None = None
        self._scratch = np.zeros(KEYFRAME_WIDTH, dtype=np.float32)

    def push_keyframe(
        self, t: float, vector: F32Array, input_time: float, lag: float = 0.0
    ) -> None:
        """Store the agent face for local time ``t`` (any thread); ``lag`` is how long the
        behaviour means it to trail ``input_time`` (copy: its delay)."""
        with self._lock:
            row = np.empty(KEYFRAME_WIDTH, dtype=np.float32)
            row[:VECTOR_SIZE] = vector
            row[VECTOR_SIZE] = t - input_time
            row[VECTOR_SIZE + 1] = lag
            if t < self._keyframes.last_time:  # the behaviour side restarted on a new grid
                self._keyframes = FrameHistory(32, width=KEYFRAME_WIDTH, max_gap=0.25)
                self.keyframe_resets += 1
            if self._keyframes.append(t, row):
                self.keyframes_in += 1

    def tick(self, t: float) -> float:
        """Render the frame for scheduled time ``t``; returns its participant input time."""
        if self._last_tick is not None:
            skipped = round((t - self._last_tick) * self.config.tick_rate) - 1
            if skipped > 0:
                self._fill_filter(t, skipped)
        self._last_tick = t
        with self._lock:
            newest = self._keyframes.last_time
            found = self._keyframes.sample(t, self._sample)
        if math.isnan(found):
            self._sample[:] = 0.0  # no keyframe yet: neutral
            self._sample[VECTOR_SIZE] = math.nan
        elif t > newest:
            self.underruns += 1
        self.lag = float(self._sample[VECTOR_SIZE + 1])
        agent = self.agent
        self.lipsync.apply(t, agent)
        head = self.filter.push(agent[HEAD_SLICE])
        self.driver.send_head(float(head[0]), float(head[1]), float(head[2]))
        self._face_phase += self._face_step
        if self._face_phase >= 1.0 - 1e-9:
            self._face_phase -= 1.0
            self.driver.send_face(agent[:N_BLENDSHAPES])
        return t - float(self._sample[VECTOR_SIZE])

    def _fill_filter(self, t: float, skipped: int) -> None:
        """Feed the head filter the ticks the loop skipped (sampled, not sent), so its time
        base stays uniform and its group delay stays what it says."""
        period = 1.0 / self.config.tick_rate
        for j in range(min(skipped, len(self.filter.taps)), 0, -1):
            with self._lock:
                found = self._keyframes.sample(t - j * period, self._scratch)
            if not math.isnan(found):
                self.filter.push(self._scratch[HEAD_SLICE])


class TickStats:
    """Tick intervals and lateness in preallocated rings; summarised once a second."""

    def __init__(self, period: float, size: int = 1 << 16) -> None:
        self.period = period
        self.intervals: F64Array = np.zeros(size)
        self.lateness: F64Array = np.zeros(size)
        self.count = 0
        self.missed = 0
        self._reported = 0
        self._last = math.nan

    def record(self, now: float, late: float) -> None:
        i = self.count % len(self.intervals)
        self.intervals[i] = now - self._last if self.count else self.period
        self.lateness[i] = late
        self._last = now
        self.count += 1

    def recent_jitter(self, since: int | None = None) -> F64Array:
        """|interval - period| for ticks after index ``since`` (default: last report)."""
        start = self._reported if since is None else since
        n = min(self.count - start, len(self.intervals))
        idx = np.arange(self.count - n, self.count) % len(self.intervals)
        return np.abs(self.intervals[idx] - self.period)

    def summary(self) -> dict[str, float]:
        """Jitter percentiles (ms) since the last summary; resets the window."""
        jitter = self.recent_jitter()
        ticks = len(jitter)
        self._reported = self.count
        if not ticks:
            return {"ticks": 0, "jitter_p50_ms": 0.0, "jitter_p99_ms": 0.0, "jitter_max_ms": 0.0}
        p50, p99 = np.percentile(jitter, [50, 99]) * 1e3
        return {"ticks": ticks, "jitter_p50_ms": float(p50), "jitter_p99_ms": float(p99),
                "jitter_max_ms": float(jitter.max() * 1e3)}  # fmt: skip


class RenderLoop:
    """Deadline-based fixed-rate loop: tick ``k`` is due at ``k / rate`` on ``clock``; a tick
    more than one period late skips the missed deadlines (counted) instead of bunching."""

    def __init__(
        self, rate: float, on_tick: Callable[[float, float], None], *,
        clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep,
    ) -> None:  # fmt: skip
        self.period = 1.0 / rate
        self.on_tick = on_tick  # (scheduled time, actual time)
        self.clock, self.sleep = clock, sleep
        self.stats = TickStats(self.period)

    def run(self, stop: threading.Event, max_ticks: int | None = None) -> None:
        period, clock, stats = self.period, self.clock, self.stats
        k = math.ceil(clock() / period)
        done = 0
        while not stop.is_set() and (max_ticks is None or done < max_ticks):
            due = k * period
            wait = due - clock()
            if wait > 0:
                self.sleep(wait)
            now = clock()
            behind = int((now - due) // period)
            if behind > 0:  # skip deadlines already past; render the latest one
                stats.missed += behind
                k += behind
                due = k * period
            stats.record(now, now - due)
            self.on_tick(due, now)
            k += 1
            done += 1
