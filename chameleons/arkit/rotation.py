"""Head-rotation convention shared by every capture source.

Angles are degrees about the ARKit face frame's axes (+x the viewer's right, +y up, +z out
of the face towards the camera), composed as ``R = Ry(yaw) @ Rx(pitch) @ Rz(roll)``
(yaw first, then pitch, then roll, each about the already-turned axes):

- yaw: about +y; positive turns the nose towards +x, the viewer's right (subject's left);
- pitch: about +x; positive tips the nose down (chin towards the chest);
- roll: about +z; positive lifts the viewer's-right side of the head (tilt towards the
  subject's right shoulder).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

F64Array = npt.NDArray[np.float64]


def rotation_matrix(yaw: float, pitch: float, roll: float) -> F64Array:
    """The 3x3 rotation ``Ry(yaw) @ Rx(pitch) @ Rz(roll)`` for angles in degrees."""
    y, p, r = (math.radians(a) for a in (yaw, pitch, roll))
    cy, sy, cp, sp, cr, sr = (
        math.cos(y),
        math.sin(y),
        math.cos(p),
        math.sin(p),
        math.cos(r),
        math.sin(r),
    )
    return np.array(
        [
            [cy * cr + sy * sp * sr, -cy * sr + sy * sp * cr, sy * cp],
            [cp * sr, cp * cr, -sp],
            [-sy * cr + cy * sp * sr, sy * sr + cy * sp * cr, cy * cp],
        ]
    )


def yaw_pitch_roll(rotation: F64Array) -> tuple[float, float, float]:
    """Inverse of :func:`rotation_matrix` (degrees; pitch in -90..90)."""
    r = rotation
    pitch = math.asin(max(-1.0, min(1.0, -float(r[1, 2]))))
    if abs(float(r[1, 2])) > 1 - 1e-9:  # gimbal lock: yaw and roll share one axis
        yaw = math.atan2(-float(r[2, 0]), float(r[0, 0]))
        return math.degrees(yaw), math.degrees(pitch), 0.0
    yaw = math.atan2(float(r[0, 2]), float(r[2, 2]))
    roll = math.atan2(float(r[1, 0]), float(r[1, 1]))
    return math.degrees(yaw), math.degrees(pitch), math.degrees(roll)


def z_rotation(degrees: float) -> F64Array:
    """Rotation about +z, counter-clockwise seen from +z (the front of the phone)."""
    a = math.radians(degrees)
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
