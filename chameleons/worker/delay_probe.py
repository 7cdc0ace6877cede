"""The copy delay measured movement to movement, for the booth check.

The configured delay says what the copy behaviour *should* do; this measures what reaches
the robot: the participant's head yaw as captured (frame capture times on this host's
clock) against the head yaw the renderer sent to the robot (send times), over the last
``window_s`` seconds. Both are resampled on one grid and the lag with the highest
correlation is the delay (refined between grid points by a parabola through the peak). It
includes everything after the capture: the behaviour's delay, the head filter's group
delay net of its look-ahead, and the renderer's send timing. A window without head movement
(less than ``min_motion_deg`` of yaw range) or without a clear match gives no figure. A
copy whose yaw is the captured yaw negated (a condition whose ``mirror`` differs from the
booth's) matches too, and says ``mirrored``. At that lag the slope of the sent yaw on the
captured yaw (least squares, sign dropped) is the copy's realised ``gain`` on the head turn:
1 for a copy of the same amplitude, the condition's ``gain`` otherwise (the booth check
judges it).

The brows are watched over the same window (:meth:`DelayProbe.brows`): how far the
participant's brows moved (the largest of the brow-raise blendshapes, peak to peak) and how
far the robot's moved, so the check can say whether a condition that copies the head only
left the brows at neutral (and, their ratio, whether a brow gain was applied).
"""

from __future__ import annotations

import threading
from collections import deque
from typing import Any

import numpy as np


class DelayProbe:
    def __init__(self, window_s: float = 20.0, rate_hz: float = 50.0, max_lag_s: float = 12.0,
                 min_motion_deg: float = 5.0, min_correlation: float = 0.8) -> None:  # fmt: skip
        self.window_s, self.rate_hz, self.max_lag_s = window_s, rate_hz, max_lag_s
        self.min_motion_deg, self.min_correlation = min_motion_deg, min_correlation
        size = int(window_s * 200)  # up to 200 frames a second of either stream
        self._captured: deque[tuple[float, float]] = deque(maxlen=size)
        self._sent: deque[tuple[float, float]] = deque(maxlen=size)
        self._brows_in: deque[tuple[float, float]] = deque(maxlen=size)
        self._brows_out: deque[tuple[float, float]] = deque(maxlen=size)
        self._lock = threading.Lock()

    def captured(self, capture_time: float, yaw: float) -> None:
        with self._lock:
            self._captured.append((capture_time, yaw))

    def sent(self, send_time: float, yaw: float) -> None:
        with self._lock:
            self._sent.append((send_time, yaw))

    def brow_captured(self, capture_time: float, raised: float) -> None:
        with self._lock:
            self._brows_in.append((capture_time, raised))

    def brow_sent(self, send_time: float, raised: float) -> None:
        with self._lock:
            self._brows_out.append((send_time, raised))

    def reset(self) -> None:
        """Forget everything seen so far (the booth check's copy step starts)."""
        with self._lock:
            for seen in (self._captured, self._sent, self._brows_in, self._brows_out):
                seen.clear()

    def brows(self, now: float) -> dict[str, float] | None:
        """``{"captured", "sent"}``: peak-to-peak brow raise of the participant and of the
        robot over the last window (None: too few frames of either)."""
        start = now - self.window_s
        with self._lock:
            captured = [v for t, v in self._brows_in if t >= start]
            sent = [v for t, v in self._brows_out if t >= start]
        if len(captured) < 10 or len(sent) < 10:
            return None
        return {"captured": round(max(captured) - min(captured), 3),
                "sent": round(max(sent) - min(sent), 3)}  # fmt: skip

    def measure(self, now: float) -> dict[str, Any] | None:
        """``{"delay_s", "correlation", "motion_deg", "mirrored", "gain"}`` for the last
        window, or None."""
        start = now - self.window_s
        with self._lock:
            captured = np.array([p for p in self._captured if p[0] >= start], dtype=np.float64)
            sent = np.array([p for p in self._sent if p[0] >= start], dtype=np.float64)
        if len(captured) < 10 or len(sent) < 10:
            return None
        motion = float(np.ptp(captured[:, 1]))
        if motion < self.min_motion_deg:
            return None
        first = min(captured[0, 0], sent[0, 0])
        grid = np.arange(first, max(captured[-1, 0], sent[-1, 0]), 1.0 / self.rate_hz)
        if len(grid) < self.rate_hz:
            return None
        a = np.interp(grid, captured[:, 0], captured[:, 1])
        b = np.interp(grid, sent[:, 0], sent[:, 1])
        scores, slopes = self._correlations(a, b)
        if not scores.size or not np.isfinite(scores).any():
            return None
        best = int(np.nanargmax(scores))
        mirrored = False
        if scores[best] < self.min_correlation:  # a copy as the other side's mirror image?
            flipped = -scores
            best = int(np.nanargmax(flipped))
            if flipped[best] < self.min_correlation:
                return None
            scores, mirrored = flipped, True
        return {"delay_s": round(self._refine(scores, best) / self.rate_hz, 3),
                "correlation": round(float(scores[best]) * (-1 if mirrored else 1), 3),
                "motion_deg": round(motion, 1), "mirrored": mirrored,
                "gain": round(abs(float(slopes[best])), 3)}  # fmt: skip

    def _correlations(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pearson correlation of ``a`` with ``b`` shifted later by each lag, and the slope
        of ``b`` on ``a`` at each lag, all lags at once (one C-level correlation plus
        running sums: this runs in a worker thread beside the 125 Hz renderer, so no Python
        loop over lags). NaN where either side does not move, or the overlap is under a
        second."""
        n = len(a)
        lags = min(int(self.max_lag_s * self.rate_hz), n - int(self.rate_hz))
        if lags < 0:
            return np.array([]), np.array([])
        k = np.arange(lags + 1)
        m = (n - k).astype(np.float64)
        # sum_i a[i] * b[i + k] for each k: the "full" correlation's tail, lag 0 first.
        sxy = np.correlate(b, a, mode="full")[n - 1 : n + lags]
        ca, ca2 = np.concatenate(([0.0], np.cumsum(a))), np.concatenate(([0.0], np.cumsum(a * a)))
        cb, cb2 = np.concatenate(([0.0], np.cumsum(b))), np.concatenate(([0.0], np.cumsum(b * b)))
        sx, sx2 = ca[n - k], ca2[n - k]  # a[: n - k]
        sy, sy2 = cb[n] - cb[k], cb2[n] - cb2[k]  # b[k:]
        vx, vy = sx2 - sx * sx / m, sy2 - sy * sy / m
        cov = sxy - sx * sy / m
        with np.errstate(invalid="ignore", divide="ignore"):
            scores = cov / np.sqrt(vx * vy)
            slopes = cov / vx
        flat = (vx < 1e-9 * m) | (vy < 1e-9 * m)
        scores[flat] = np.nan
        return np.asarray(scores, dtype=np.float64), np.asarray(slopes, dtype=np.float64)

    @staticmethod
    def _refine(scores: np.ndarray, k: int) -> float:
        if 0 < k < len(scores) - 1 and np.isfinite(scores[k - 1 : k + 2]).all():
            left, mid, right = scores[k - 1], scores[k], scores[k + 1]
            bend = left - 2 * mid + right
            if bend < 0:
                return float(k + 0.5 * (left - right) / bend)
        return float(k)
