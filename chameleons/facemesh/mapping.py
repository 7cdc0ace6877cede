"""Landmarks -> a face reading: head pose, ARKit's 52 values, eye rotations.

The one implementation of the science every webcam path uses: the capture page's landmarks
(sent over the WebSocket, mapped in the booth's worker), the Python tracker's (``chameleons
worker --camera``, ``chameleons face-track``) and the calibration against the iPhone.
:class:`Calibration` is what adapts it to a face and a booth: the participant's neutral face
and, where a lab taught it with its iPhone, a learned map.

Pure functions: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from chameleons.facemesh.arkit import LinearMap, default_neutral, expression, geometric_map
from chameleons.facemesh.features import measure
from chameleons.facemesh.pose import F64Array, fit_pose

GEOMETRIC = "geometric"


@dataclass(frozen=True)
class Calibration:
    """The neutral face (features at rest; None: the default neutral) and the map from
    features to blendshapes (the geometric defaults unless a teacher's map is given)."""

    neutral: F64Array | None = None
    mapping: LinearMap = field(default_factory=geometric_map)

    @property
    def neutral_calibrated(self) -> bool:
        return self.neutral is not None

    def label(self) -> str:
        """What the data says about it: ``geometric`` / ``neutral`` /
        ``iphone:<hash>`` / ``neutral+iphone:<hash>``."""
        parts = ["neutral"] if self.neutral is not None else []
        if self.mapping.name != GEOMETRIC:
            parts.append(self.mapping.name)
        return "+".join(parts) or GEOMETRIC


@dataclass(frozen=True, slots=True)
class FaceReading:
    """One frame's face: head yaw/pitch/roll (degrees), 52 blendshapes (NaN = missing),
    eye rotations (degrees), the missing channels, and the features (for calibration)."""

    head: tuple[float, float, float]
    blendshapes: F64Array
    eyes: F64Array
    missing: tuple[int, ...]
    features: F64Array


def read_face(landmarks: npt.ArrayLike, width: int, height: int,
              calibration: Calibration | None = None) -> FaceReading:  # fmt: skip
    """Map one face's landmarks (468 or 478, normalised as MediaPipe gives them) from an
    image of ``width`` x ``height``; raises ``PoseError``/``FeatureError`` (ValueErrors)."""
    calibration = calibration or Calibration()
    pose = fit_pose(landmarks, width, height)
    features = measure(pose.metric)
    neutral = calibration.neutral if calibration.neutral is not None else default_neutral()
    face = expression(features, neutral, calibration.mapping)
    return FaceReading((pose.yaw, pose.pitch, pose.roll), face.blendshapes, face.eyes,
                       face.missing, features)  # fmt: skip


def robot_values(blendshapes: npt.ArrayLike) -> npt.NDArray[np.float32]:
    """Blendshapes as the robot takes them: missing channels at rest (0)."""
    return np.nan_to_num(np.asarray(blendshapes, dtype=np.float32), nan=0.0)
