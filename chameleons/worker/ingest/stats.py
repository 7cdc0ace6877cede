"""Ingest bookkeeping: per-reason drop counters, the input frame rate, the sender's clock."""

from __future__ import annotations

import threading
import time
from collections import Counter, deque
from collections.abc import Callable
from typing import Any

HEAD_WINDOW_SECONDS = 15.0  # without a resting pose: the extremes of the last 15 s
MAX_MOVEMENT_SECONDS = 60.0  # a resting pose older than this is forgotten (the check's turn
# and nod take at most 30 s each)


class CaptureStats:
    """Thread-safe counters a receiver updates and telemetry reads (:meth:`snapshot`)."""

    def __init__(self, clock: Callable[[], float] = time.monotonic, window_s: float = 2.0) -> None:
        self._clock, self._window = clock, window_s
        self._lock = threading.Lock()
        self._drops: Counter[str] = Counter()
        self._times: deque[float] = deque(maxlen=1024)
        self._no_face: deque[float] = deque(maxlen=1024)
        # (receive time, yaw, pitch) of the participant's head, for the booth check's
        # "turn your head left, then nod" step (degrees, the participant's own frame).
        self._heads: deque[tuple[float, float, float]] = deque(maxlen=4096)
        # The resting pose the booth check measured (yaw, pitch, frames, seconds) and when:
        # the head's movement since then is judged against it, not against zero.
        self._rest: tuple[float, float, int, float] | None = None
        self._rest_at = -1e18
        self.timecode: Callable[[], dict[str, Any]] | None = None  # the receiver's guard
        self.no_face = 0  # "the phone sees no face" packets (not errors)
        self.problem: str | None = None  # what the lab must change (e.g. the app's mode)
        self._problem_at = -1e18
        self.frames = 0
        self.unknown_names = 0
        self.bad_fields = 0
        self.connections = 0
        self.connected = False

    def count_frame(self, receive_time: float) -> None:
        with self._lock:
            self.frames += 1
            self._times.append(receive_time)

    def count_no_face(self, receive_time: float) -> None:
        with self._lock:
            self.no_face += 1
            self._no_face.append(receive_time)

    def note_head(self, receive_time: float, yaw: float, pitch: float) -> None:
        with self._lock:
            self._heads.append((receive_time, yaw, pitch))

    def mark_rest(self, seconds: float) -> dict[str, Any] | None:
        """The booth check's "hold still" is over: the resting pose is the mean of the last
        ``seconds``, and :meth:`head_range` reports the movement from now on (None: no
        frames to measure it from)."""
        now = self._clock()
        with self._lock:
            still = [(y, p) for t, y, p in self._heads if now - seconds <= t <= now]
            self._rest_at = now
            self._rest = None if not still else (
                sum(y for y, _ in still) / len(still), sum(p for _, p in still) / len(still),
                len(still), seconds)  # fmt: skip
        return self._rest_dict()

    @property
    def rest_marked_at(self) -> float | None:
        """When the booth check last took the resting pose (this stats' clock), or None."""
        return None if self._rest_at < -1e17 else self._rest_at

    def _rest_dict(self) -> dict[str, Any] | None:
        if self._rest is None:
            return None
        yaw, pitch, frames, seconds = self._rest
        return {"yaw": round(yaw, 1), "pitch": round(pitch, 1), "frames": frames,
                "seconds": seconds}  # fmt: skip

    def head_range(self, seconds: float = HEAD_WINDOW_SECONDS) -> dict[str, Any] | None:
        """Extremes of yaw and pitch (None: no frames): since the resting pose was measured
        (``rest``, when it was within :data:`MAX_MOVEMENT_SECONDS`), else over the last
        ``seconds`` (``rest`` None)."""
        now = self._clock()
        with self._lock:
            marked = now - self._rest_at <= MAX_MOVEMENT_SECONDS
            since = self._rest_at if marked else now - seconds
            recent = [(y, p) for t, y, p in self._heads if t >= since]
            rest = self._rest_dict() if marked else None
        if not recent:
            return None
        yaws, pitches = [y for y, _ in recent], [p for _, p in recent]
        return {"yaw_min": round(min(yaws), 1), "yaw_max": round(max(yaws), 1),
                "pitch_min": round(min(pitches), 1), "pitch_max": round(max(pitches), 1),
                "frames": len(recent), "rest": rest}  # fmt: skip

    def set_problem(self, text: str) -> None:
        with self._lock:
            self.problem, self._problem_at = text, self._clock()

    def count_drop(self, reason: str, n: int = 1) -> None:
        with self._lock:
            self._drops[reason] += n

    def count_unknown(self, names: int, bad_fields: int) -> None:
        with self._lock:
            self.unknown_names += names
            self.bad_fields += bad_fields

    def set_connected(self, connected: bool) -> None:
        with self._lock:
            self.connections += int(connected)
            self.connected = connected

    @property
    def drops(self) -> dict[str, int]:
        with self._lock:
            return dict(self._drops)

    @property
    def input_fps(self) -> float:
        """Frames per second over the last ``window_s`` seconds (0 when the input stopped)."""
        now = self._clock()
        with self._lock:
            recent = [t for t in self._times if now - t <= self._window]
        if len(recent) < 2 or recent[-1] <= recent[0]:
            return 0.0
        return (len(recent) - 1) / (recent[-1] - recent[0])

    def _recent(self, times: deque[float]) -> list[float]:
        now = self._clock()
        return [t for t in times if now - t <= self._window]

    def snapshot(self) -> dict[str, Any]:
        fps, drops, heads = self.input_fps, self.drops, self.head_range()
        with self._lock:
            no_face_recent = bool(self._recent(self._no_face))
            problem_recent = self._clock() - self._problem_at <= self._window
            return {
                "frames": self.frames,
                "input_fps": fps,
                "drops": drops,
                "dropped": sum(drops.values()),
                "unknown_names": self.unknown_names,
                "bad_fields": self.bad_fields,
                "connected": self.connected,
                "connections": self.connections,
                "no_face": self.no_face,
                "no_face_recent": no_face_recent,  # the phone sees no face right now
                "problem": self.problem if problem_recent else None,
                "head_range": heads,
                "timecode": self.timecode() if self.timecode is not None else None,
            }


class ClockAligner:
    """Maps the sender's clock onto this host's monotonic clock: ``local = sender + offset``.

    The offset follows the least-delayed frame (the smallest ``receive - sender``), so network
    jitter stays out of capture times and ``capture_time <= receive_time``; capture times
    increase whenever both the sender's and the receive times do (a drop of the offset lands
    exactly on the new receive time, later than every earlier capture time). It may creep
    up by ``max_drift`` seconds per second (clock drift) and restarts when the sender's
    clock jumps by more than ``jump_s`` (app restart, timecode wrapping at midnight).
    """

    def __init__(self, jump_s: float = 1.0, max_drift: float = 1e-3) -> None:
        self.jump_s, self.max_drift = jump_s, max_drift
        self.offset: float | None = None
        self.restarted = False  # the last frame (re)started the mapping
        self._last_receive = 0.0

    def align(self, sender_time: float, receive_time: float) -> float:
        delay, offset = receive_time - sender_time, self.offset
        self.restarted = offset is None or abs(delay - offset) > self.jump_s
        if offset is None or self.restarted:
            offset = delay
        else:
            allowed = offset + self.max_drift * max(0.0, receive_time - self._last_receive)
            offset = min(delay, allowed)
        self.offset, self._last_receive = offset, receive_time
        return min(sender_time + offset, receive_time)  # exact even after rounding
