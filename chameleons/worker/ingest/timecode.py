"""The sender's timecode, checked before it is trusted, and frames put back in capture order.

A Live Link Face packet carries the phone's timecode (frame number and rate); the worker
maps it onto its own clock (:class:`~chameleons.worker.ingest.stats.ClockAligner`) so that
network jitter stays out of the copy's timing. The app's timecode source is a setting
(System Timer, NTP, Tentacle Sync: Epic's "Recording Facial Animation from an iOS Device",
*Timecode Sources*); a source that stalls or resets breaks that mapping: a frozen timecode
stamped every frame with one time, and the copy ran 9.5 s wrong. So :class:`TimecodeGuard`
watches it and falls back to the arrival time, with a reason, while it is:

- **frozen**: no newer timecode for ``frozen_s`` while frames keep arriving (at least
  ``frozen_frames`` of them: a pause in the stream is not a frozen timecode);
- **jumping**: the mapping had to restart (a jump of more than ``jump_s``) more than
  ``max_jumps`` times within ``jump_window_s`` (one restart, as when the app restarts or the
  timecode wraps at midnight, is expected and fine);
- **drifting**: even the least-delayed frame of the last ``lag_window_s`` arrived more than
  ``max_lag_s`` after its mapped capture time (a sender clock that runs slow: the mapping
  may follow drift only slowly).

It trusts the timecode again once none of these has been seen for ``recover_s``.

:class:`ReorderBuffer` holds each frame until ``window_s`` after its capture time and
releases frames in capture order: UDP may deliver a later frame first (at 0-40 ms of
jitter, 17.5 % of frames came out of order and were dropped). That costs up to
``window_s`` of latency before the behaviour; the copy samples by capture time, so its
delay stays exact. A frame later than the window is dropped and counted (``late``).
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections import deque
from dataclasses import dataclass
from typing import Any

from chameleons.worker.frames import FaceFrame
from chameleons.worker.ingest.stats import ClockAligner

REORDER_WINDOW_S = 0.05  # Live Link (UDP); a TCP stream arrives in order and is not held
FROZEN, JUMPING, DRIFTING = "frozen", "jumping", "drifting"
PROBLEMS = {
    FROZEN: "the phone's timecode is frozen",
    JUMPING: "the phone's timecode keeps jumping",
    DRIFTING: "the phone's timecode drifts from the arrival times",
}


@dataclass(frozen=True, slots=True)
class TimecodeLimits:
    frozen_s: float = 0.25
    frozen_frames: int = 8
    jump_s: float = 1.0
    max_jumps: int = 2
    jump_window_s: float = 10.0
    max_lag_s: float = 0.25
    lag_window_s: float = 1.0
    recover_s: float = 5.0


class TimecodeGuard:
    """Maps the sender's clock onto this host's (aligned), or falls back to arrival time."""

    def __init__(self, limits: TimecodeLimits | None = None) -> None:
        self.limits = limits or TimecodeLimits()
        self.aligner = ClockAligner(jump_s=self.limits.jump_s)
        self.problem: str | None = None  # FROZEN, JUMPING or DRIFTING while falling back
        self.fallbacks = 0  # times the guard stopped trusting the timecode
        self.jumps = 0
        self._newest = -math.inf  # the newest sender time seen
        self._newest_at = -math.inf  # when it arrived
        self._stale = 0  # frames since, none newer
        self._jumps: deque[float] = deque()
        self._lags: deque[tuple[float, float]] = deque()  # (receive, lag), lags rising
        self._lag_since = -math.inf  # first receive time of the window the lags cover
        self._seen_at = -math.inf  # last time a problem was seen

    def capture_time(self, sender_time: float, receive_time: float) -> float:
        """The frame's capture time on this host's clock."""
        first = self.aligner.offset is None
        aligned = self.aligner.align(sender_time, receive_time)
        found = (self._frozen(sender_time, receive_time), self._jumped(first, receive_time),
                 self._drifting(receive_time - aligned, receive_time))  # fmt: skip
        seen = next((problem for problem in found if problem is not None), None)
        if seen is not None:
            if self.problem is None:
                self.fallbacks += 1
            self.problem, self._seen_at = seen, receive_time
        elif self.problem is not None and receive_time - self._seen_at >= self.limits.recover_s:
            self.problem = None
        return receive_time if self.problem is not None else aligned

    def _frozen(self, sender_time: float, receive_time: float) -> str | None:
        if sender_time > self._newest or self.aligner.restarted:  # (a jump back starts anew)
            self._newest, self._newest_at, self._stale = sender_time, receive_time, 0
            return None
        self._stale += 1
        stalled = receive_time - self._newest_at >= self.limits.frozen_s
        return FROZEN if stalled and self._stale >= self.limits.frozen_frames else None

    def _jumped(self, first: bool, receive_time: float) -> str | None:
        if self.aligner.restarted and not first:
            self.jumps += 1
            self._jumps.append(receive_time)
        while self._jumps and self._jumps[0] < receive_time - self.limits.jump_window_s:
            self._jumps.popleft()
        return JUMPING if len(self._jumps) > self.limits.max_jumps else None

    def _drifting(self, lag: float, receive_time: float) -> str | None:
        """The least lag over the last ``lag_window_s`` (a sliding minimum)."""
        lags, window = self._lags, self.limits.lag_window_s
        if self.aligner.restarted:  # a new mapping: the lags before it say nothing now
            lags.clear()
            self._lag_since = receive_time
        while lags and lags[-1][1] >= lag:
            lags.pop()
        lags.append((receive_time, lag))
        while lags[0][0] < receive_time - window:
            lags.popleft()
        covered = receive_time - self._lag_since >= window
        return DRIFTING if covered and lags[0][1] > self.limits.max_lag_s else None

    def snapshot(self) -> dict[str, Any]:
        return {"trusted": self.problem is None, "problem": self.problem,
                "detail": PROBLEMS.get(self.problem or ""), "fallbacks": self.fallbacks,
                "jumps": self.jumps}  # fmt: skip


class ReorderBuffer:
    """Frames held until ``window_s`` after their capture time, released in capture order."""

    def __init__(self, window_s: float) -> None:
        self.window_s = window_s
        self._heap: list[tuple[float, int, FaceFrame]] = []
        self._order = itertools.count()
        self._released = -math.inf  # capture time of the newest frame released
        self._newest = -math.inf  # newest capture time pushed
        self.reordered = 0  # frames that arrived after a later one and were put back in place
        self.late = 0  # frames that arrived after a later one had been released: dropped

    def push(self, frame: FaceFrame) -> bool:
        """Hold ``frame``; False (dropped, counted) when it comes too late to be in order."""
        t = frame.capture_time
        if t <= self._released:
            self.late += 1
            return False
        if t < self._newest:
            self.reordered += 1
        self._newest = max(self._newest, t)
        heapq.heappush(self._heap, (t, next(self._order), frame))
        return True

    def due(self, now: float) -> list[FaceFrame]:
        """The frames whose wait is over, oldest capture first."""
        ready: list[FaceFrame] = []
        heap = self._heap
        while heap and heap[0][0] <= now - self.window_s:
            t, _, frame = heapq.heappop(heap)
            self._released = t
            ready.append(frame)
        return ready

    def wait(self, now: float) -> float | None:
        """Seconds until the next frame is due (None: nothing held)."""
        if not self._heap:
            return None
        return max(0.0, self._heap[0][0] + self.window_s - now)

    def __len__(self) -> int:
        return len(self._heap)
