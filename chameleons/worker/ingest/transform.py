"""Normalisation applied to every captured frame: mounting rotation, then mirroring.

Mounting rotation: the phone may sit rotated about its viewing axis (the original study's
mount needed 90 degrees counter-clockwise). The head rotation is corrected as
``R' = Rz(mounting_rotation_deg) @ R`` (counter-clockwise seen from the front of the phone),
so set it such that an upright head reads roll ~0. Eye rotations are relative to the head
and stay as they are.

Mirror (setting ``mirror``): the robot copies as a mirror image (Left/Right channels swapped,
yaw and roll negated, :meth:`FaceFrame.mirrored`) instead of the same side.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from chameleons.worker.frames import FaceFrame
from chameleons.worker.ingest.rotation import rotation_matrix, yaw_pitch_roll, z_rotation


class CaptureSettings(Protocol):
    mounting_rotation_deg: float
    mirror: bool


def apply_mounting_rotation(frame: FaceFrame, degrees: float) -> FaceFrame:
    """The frame with its head pose rotated about the camera's viewing axis."""
    if degrees % 360 == 0:
        return frame
    head = yaw_pitch_roll(z_rotation(degrees) @ rotation_matrix(*(float(a) for a in frame.head)))
    return dataclasses.replace(frame, head=np.array(head, dtype=np.float32))


@dataclass(frozen=True, slots=True)
class FrameTransform:
    """What ingest does to each frame before publishing it."""

    mounting_rotation_deg: float = 0.0
    mirror: bool = False

    @classmethod
    def from_settings(cls, settings: CaptureSettings) -> FrameTransform:
        return cls(settings.mounting_rotation_deg, settings.mirror)

    def apply(self, frame: FaceFrame) -> FaceFrame:
        rotated = apply_mounting_rotation(frame, self.mounting_rotation_deg)
        return rotated.mirrored() if self.mirror else rotated
