"""The participant's neutral head pose, on which the ``copy`` behaviour re-centres the head.

A phone rarely sits straight in front of the face: a real capture rests at +14.7 degrees of
pitch (the phone below the face), and a robot copying that pose looks 15 degrees down at
rest. With re-centring on (the booth's ``head_recentre`` setting, default on), the copied
yaw, pitch and roll are the participant's minus this neutral pose, so the robot looks
straight ahead when the participant rests, and moves as far as the participant moves.

Epic's own material does the same with a neutral captured at a calibration moment (the
Face AR Sample records the current values as the new zero; the MetaHuman Live Link subject
keeps a neutral head orientation; docs/livelink.md has the sources). A participant cannot be
asked to hold still for it, so the neutral here is their **mean pose**:

- :meth:`HeadNeutral.restart` (a worker starting, a new participant: the server sends
  ``recentre_head`` with the pairing reset at each session start, and the wizard's "pair
  again" does too): the mean over the next ``calibration_s`` seconds of frames, a running
  mean until then (so the offset converges in the first frames, without a jump), frozen
  after;
- :meth:`HeadNeutral.capture` (the booth check, after its "hold still" phase): the mean of
  the frames of the last ``seconds``, frozen at once.

The neutral is undone as a rotation (:meth:`HeadNeutral.relative`: ``Rn^T @ R``, as the
mounting rotation is applied), not angle by angle: a phone 14.7 degrees below the face
reads a 40 degree turn as yaw 40.9, pitch 11.2, roll 9.6; subtracting the neutral's pitch
per angle (as the Face AR Sample re-zeroes each curve) leaves a 9.6 degree roll the
participant never made, undoing the rotation gives the turn alone (40, 0, 0).

Cost: :meth:`add` is three additions per participant frame while calibrating (nothing once
frozen); :meth:`relative` is one 3x3 product and two small trigonometric conversions per
sampled keyframe, in the behaviour stage, which publishes keyframes ahead of the renderer:
the renderer's 125 Hz tick does nothing new. Each change of the neutral is reported
(:meth:`describe`: the pose, how it was measured, over how many frames) and logged with the
running session.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from chameleons.worker.behaviours.history import FrameHistory
from chameleons.worker.frames import N_BLENDSHAPES, F32Array
from chameleons.worker.ingest.rotation import F64Array, rotation_matrix, yaw_pitch_roll

DEFAULT_CALIBRATION_S = 20.0
HEAD = slice(N_BLENDSHAPES, N_BLENDSHAPES + 3)
CALIBRATED, CAPTURED, CALIBRATING = "mean_of_first_frames", "mean_of_rest", "calibrating"


class HeadNeutral:
    """The neutral (yaw, pitch, roll) in degrees; use it from the behaviour stage's thread."""

    def __init__(self, calibration_s: float = DEFAULT_CALIBRATION_S) -> None:
        if not calibration_s > 0:
            raise ValueError("the head's calibration needs a positive number of seconds")
        self.calibration_s = calibration_s
        self.value: F32Array | None = None  # None: no frame seen since the last restart
        self.how = CALIBRATING
        self.frozen = False
        self.changed = False  # set when the neutral froze; the stage reports and clears it
        self.restarts = 0
        self._sums = [0.0, 0.0, 0.0]
        self._frames = 0
        self._first = math.nan
        self._last = math.nan
        self._version = 0  # counts changes of ``value``; the inverse is made per version
        self._inverse: tuple[int, F64Array] | None = None
        self._since = -math.inf  # frames captured before this are not measured

    def restart(self, since: float = -math.inf) -> None:
        """Measure afresh: the mean of the next ``calibration_s`` seconds of frames captured
        at ``since`` or later. A frame captured before it (the person before, still in the
        pipeline's queues when the command came) is not the new participant's."""
        self._since = since
        self.value, self.how, self.frozen = None, CALIBRATING, False
        self._version += 1
        self._sums, self._frames = [0.0, 0.0, 0.0], 0
        self._first = self._last = math.nan
        self.restarts += 1

    def add(self, t: float, head: F32Array) -> None:
        """A participant frame captured at local time ``t`` (head in degrees)."""
        if self.frozen or t < self._since:
            return
        if self._frames == 0:
            self._first = t
            self.value = np.zeros(3, dtype=np.float32)
        sums = self._sums
        sums[0] += float(head[0])
        sums[1] += float(head[1])
        sums[2] += float(head[2])
        self._frames += 1
        self._last = t
        assert self.value is not None
        n = self._frames
        self.value[0], self.value[1], self.value[2] = sums[0] / n, sums[1] / n, sums[2] / n
        self._version += 1
        if t - self._first >= self.calibration_s:
            self.frozen, self.how, self.changed = True, CALIBRATED, True

    def capture(self, history: FrameHistory, now: float, seconds: float) -> bool:
        """Freeze on the mean of the frames captured in the last ``seconds`` before ``now``
        (False, nothing changed, when there are none)."""
        times, values = history.window()
        recent = values[(times >= now - seconds) & (times <= now)]
        if not len(recent):
            return False
        self.value = recent[:, HEAD].astype(np.float64).mean(axis=0).astype(np.float32)
        self.how, self.frozen, self.changed = CAPTURED, True, True
        self._version += 1
        self._frames = len(recent)
        self._first, self._last = float(times[times >= now - seconds][0]), now
        return True

    def relative(self, head: F32Array) -> None:
        """Re-centre ``head`` (yaw, pitch, roll in degrees, in place) on the neutral: the
        neutral's rotation undone, ``Rn^T @ R``. Nothing while there is no neutral."""
        if self.value is None:
            return
        if self._inverse is None or self._inverse[0] != self._version:
            neutral = rotation_matrix(*(float(v) for v in self.value))
            self._inverse = (self._version, neutral.T.copy())
        pose = rotation_matrix(float(head[0]), float(head[1]), float(head[2]))
        head[0], head[1], head[2] = yaw_pitch_roll(self._inverse[1] @ pose)

    def describe(self) -> dict[str, Any]:
        """The neutral as reported in telemetry, acks and the session's events."""
        pose = None if self.value is None else {
            name: round(float(v), 2) for name, v in zip(("yaw", "pitch", "roll"), self.value,
                                                         strict=True)
        }  # fmt: skip
        span = self._last - self._first if self._frames else 0.0
        return {"pose": pose, "how": self.how, "frozen": self.frozen, "frames": self._frames,
                "seconds": round(span, 2), "calibration_s": self.calibration_s}  # fmt: skip
