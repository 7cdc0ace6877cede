"""Expression features of a face, measured on its landmarks in the canonical face's frame.

:func:`chameleons.facemesh.pose.fit_pose` moves the landmarks back into the canonical
face's frame (cm; +x the subject's left, +y up, +z out of the face), so head pose, distance
to the camera and position in the image are gone from them. Each feature is a coordinate or
a distance there, divided by the inter-ocular distance (between the two eyes' centres, the
midpoints of their corners) so a child's face and an adult's give alike values; the ARKit
mapping (:mod:`chameleons.facemesh.arkit`) compares them with the same face at rest.

Landmark ids are MediaPipe's face mesh (``canonical_face_model_uv_visualization.png``):
the subject's right eye 33 (outer corner) 133 (inner) 159/145 (lids), the left eye
263/362/386/374; mouth corners 61 (right) 291 (left), inner lips 13/14, outer lips 0/17,
chin 152, nose base 2; irises 468 (right) and 473 (left) in the 478-point mesh.

Pure functions: no I/O.
"""

from __future__ import annotations

from typing import Final

import numpy as np
import numpy.typing as npt

F64Array = npt.NDArray[np.float64]
IRIS_POINTS = 478
RIGHT_IRIS, LEFT_IRIS = 468, 473

# (name, side) -> landmark ids; "R" the subject's right side (x < 0), "L" the left.
_EYE = {"R": (33, 133, (159, 158, 160), (145, 153, 144)),
        "L": (263, 362, (386, 385, 387), (374, 380, 373))}  # fmt: skip
_BROW = {"R": (107, 105, 70), "L": (336, 334, 300)}  # inner, middle, outer
_CORNER = {"R": 61, "L": 291}
_UPPER_SIDE = {"R": 37, "L": 267}
_LOWER_SIDE = {"R": 84, "L": 314}
_CHEEK = {"R": 118, "L": 347}
_NOSE_WING = {"R": 129, "L": 358}
_IRIS = {"R": RIGHT_IRIS, "L": LEFT_IRIS}
NOSE_BASE, CHIN = 2, 152
UPPER_OUTER, UPPER_INNER, LOWER_INNER, LOWER_OUTER = 0, 13, 14, 17

SIDED: Final = (
    "eye_open", "lower_lid", "brow_inner", "brow_mid", "brow_outer", "corner_y", "corner_out",
    "upper_side_y", "lower_side_y", "cheek_y", "nose_wing_y",
)  # fmt: skip
CENTRAL: Final = (
    "lip_gap", "jaw_drop", "jaw_x", "mouth_width", "mouth_x", "upper_lip_y", "lower_lip_y",
    "upper_lip_thickness", "lower_lip_thickness", "lip_forward",
)  # fmt: skip
GAZE: Final = ("gaze_x_L", "gaze_y_L", "gaze_x_R", "gaze_y_R")
FEATURE_NAMES: Final[tuple[str, ...]] = (
    *(f"{name}_{side}" for name in SIDED for side in ("L", "R")), *CENTRAL, *GAZE,
)
FEATURE_INDEX: Final = {name: i for i, name in enumerate(FEATURE_NAMES)}
GAZE_INDICES: Final = tuple(FEATURE_INDEX[name] for name in GAZE)
N_FEATURES: Final = len(FEATURE_NAMES)


class FeatureError(ValueError):
    """Landmarks no features can be measured on."""


def _mean(points: F64Array, ids: tuple[int, ...]) -> F64Array:
    return points[list(ids)].mean(axis=0)  # type: ignore[no-any-return]


def eye_centre(points: F64Array, side: str) -> F64Array:
    outer, inner, _upper, _lower = _EYE[side]
    return (points[outer] + points[inner]) / 2  # type: ignore[no-any-return]


def inter_ocular(points: F64Array) -> float:
    return float(np.linalg.norm(eye_centre(points, "L") - eye_centre(points, "R")))


def measure(metric: npt.ArrayLike) -> F64Array:
    """The feature vector (:data:`FEATURE_NAMES`) of landmarks in the canonical frame.
    Gaze features are NaN without irises (468 landmarks)."""
    p = np.asarray(metric, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 468:
        raise FeatureError(f"expected at least 468 landmarks of 3 values, got {p.shape}")
    iod = inter_ocular(p)
    if not np.isfinite(iod) or iod <= 1e-6:
        raise FeatureError("the eyes coincide: no inter-ocular distance")
    out = np.full(N_FEATURES, np.nan)
    nose = p[NOSE_BASE]

    def put(name: str, value: float) -> None:
        out[FEATURE_INDEX[name]] = value / iod

    for side in ("L", "R"):
        outer, inner, upper, lower = _EYE[side]
        centre = eye_centre(p, side)
        outward = 1.0 if side == "L" else -1.0  # +x is the subject's left
        put(f"eye_open_{side}", float(_mean(p, upper)[1] - _mean(p, lower)[1]))
        put(f"lower_lid_{side}", float(_mean(p, lower)[1] - centre[1]))
        for name, index in zip(("brow_inner", "brow_mid", "brow_outer"), _BROW[side],
                               strict=True):  # fmt: skip
            put(f"{name}_{side}", float(p[index][1] - centre[1]))
        corner = p[_CORNER[side]]
        put(f"corner_y_{side}", float(corner[1] - nose[1]))
        put(f"corner_out_{side}", float(outward * (corner[0] - nose[0])))
        put(f"upper_side_y_{side}", float(p[_UPPER_SIDE[side]][1] - nose[1]))
        put(f"lower_side_y_{side}", float(p[_LOWER_SIDE[side]][1] - nose[1]))
        put(f"cheek_y_{side}", float(p[_CHEEK[side]][1] - centre[1]))
        put(f"nose_wing_y_{side}", float(p[_NOSE_WING[side]][1] - centre[1]))
        if p.shape[0] >= IRIS_POINTS:
            width = float(np.linalg.norm(p[outer] - p[inner]))
            iris = p[_IRIS[side]]
            # Across: + towards the subject's left (+x); up: + above the lids' middle.
            lids = (_mean(p, upper) + _mean(p, lower)) / 2
            out[FEATURE_INDEX[f"gaze_x_{side}"]] = float(iris[0] - centre[0]) / width
            out[FEATURE_INDEX[f"gaze_y_{side}"]] = float(iris[1] - lids[1]) / width
    put("lip_gap", float(p[UPPER_INNER][1] - p[LOWER_INNER][1]))
    put("jaw_drop", float(nose[1] - p[CHIN][1]))
    put("jaw_x", float(p[CHIN][0] - nose[0]))
    put("mouth_width", float(p[_CORNER["L"]][0] - p[_CORNER["R"]][0]))
    put("mouth_x", float((p[_CORNER["L"]][0] + p[_CORNER["R"]][0]) / 2 - nose[0]))
    put("upper_lip_y", float(p[UPPER_OUTER][1] - nose[1]))
    put("lower_lip_y", float(p[LOWER_OUTER][1] - nose[1]))
    put("upper_lip_thickness", float(p[UPPER_OUTER][1] - p[UPPER_INNER][1]))
    put("lower_lip_thickness", float(p[LOWER_INNER][1] - p[LOWER_OUTER][1]))
    put("lip_forward", float((p[UPPER_OUTER][2] + p[LOWER_OUTER][2]) / 2 - nose[2]))
    return out
