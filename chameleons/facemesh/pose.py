"""Head pose from face-mesh landmarks: MediaPipe's face-geometry pipeline, in numpy.

Input: the landmarks MediaPipe's face mesh gives (468, or 478 with the irises): ``x`` and
``y`` normalised by the image's width and height from the top-left corner, ``z`` relative
depth on the scale of ``x``. The conversion to metric space and the weighted Procrustes
fit follow ``mediapipe/modules/face_geometry/libs/geometry_pipeline.cc`` (class
``ScreenToMetricSpaceConverter``) and ``procrustes_solver.cc`` (the weighted orthogonal
Procrustes problem of D. Akca, *Generalized Procrustes analysis and its applications in
photogrammetry*, 2003, section 2.4) with the environment of MediaPipe's face-geometry
graphs: origin at the top-left corner, a perspective camera of 63 degrees vertical field
of view, near plane 1 cm. The canonical mesh and the landmark weights are the vendored
package's (:func:`chameleons.facemesh.assets.canonical_mesh`).

Output: the pose of the canonical face in the camera's frame (+x right, +y up, the camera
looking along -z; the canonical face looks along +z, so a face looking into the camera has
the identity rotation), and the landmarks moved back into the canonical face's frame (cm),
where expression features are measured free of head pose. Angles follow
:mod:`chameleons.arkit.rotation` (the ARKit face frame): yaw > 0 turns the nose to
the image's right (the subject's left, in an image that is not mirrored), pitch > 0 tips
the chin down, roll > 0 lifts the image-right side of the head.

Pure functions: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
import numpy.typing as npt

from chameleons.arkit.rotation import yaw_pitch_roll
from chameleons.facemesh.assets import canonical_mesh

F64Array = npt.NDArray[np.float64]
MESH_POINTS = 468
VERTICAL_FOV_DEG = 63.0  # MediaPipe's face-geometry environment (perspective_camera)
NEAR_CM = 1.0
_EPS = 1e-9


class PoseError(ValueError):
    """Landmarks a pose cannot be fitted to (too few, not finite, collapsed)."""


@dataclass(frozen=True, slots=True)
class Pose:
    """``rotation`` 3x3 and ``translation`` (cm) of the canonical face in camera space,
    ``scale`` the canonical-to-runtime scale; ``yaw``/``pitch``/``roll`` degrees; ``metric``
    the landmarks in the canonical face's frame (cm), irises included when given."""

    rotation: F64Array
    translation: F64Array
    scale: float
    yaw: float
    pitch: float
    roll: float
    metric: F64Array


@cache
def _canonical() -> tuple[F64Array, F64Array]:
    mesh = canonical_mesh()
    points = np.array(mesh.positions, dtype=np.float64).T  # 3 x 468
    weights = np.zeros(points.shape[1])
    for index, weight in mesh.procrustes.items():
        weights[index] = weight
    points.setflags(write=False)
    weights.setflags(write=False)
    return points, weights


def solve_weighted_procrustes(
    source: F64Array, target: F64Array, weights: F64Array
) -> F64Array:
    """The 4x4 similarity ``[sR | t]`` minimising ``sum w_i |sR a_i + t - b_i|^2``
    (``source`` and ``target`` 3 x N, ``weights`` N, non-negative); no reflection."""
    sqrt_w = np.sqrt(weights)
    total = float(weights.sum())
    if total <= _EPS:
        raise PoseError("the landmark weights are all zero")
    ws, wt = source * sqrt_w, target * sqrt_w
    centre = (ws * sqrt_w).sum(axis=1) / total
    centred = ws - np.outer(centre, sqrt_w)
    design = wt @ centred.T
    if np.linalg.norm(design) <= _EPS:
        raise PoseError("the landmarks have collapsed to a point")
    u, _s, vt = np.linalg.svd(design)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:  # a reflection: flip the weakest axis
        u[:, 2] *= -1
    rotation = u @ vt
    numerator = float(((rotation @ centred) * wt).sum())
    denominator = float((centred * ws).sum())
    if denominator <= _EPS or numerator / denominator <= _EPS:
        raise PoseError("the fitted scale is not positive")
    scaled = (numerator / denominator) * rotation
    translation = ((wt - scaled @ ws) * sqrt_w).sum(axis=1) / total
    transform = np.eye(4)
    transform[:3, :3], transform[:3, 3] = scaled, translation
    return transform


def _frustum(width: int, height: int) -> tuple[float, float, float, float]:
    """(left, bottom, width, height) of the near plane of MediaPipe's perspective camera."""
    h = 2.0 * NEAR_CM * math.tan(0.5 * math.radians(VERTICAL_FOV_DEG))
    w = width * h / height
    return -0.5 * w, -0.5 * h, w, h


def fit_pose(landmarks: npt.ArrayLike, width: int, height: int) -> Pose:
    """Fit the canonical face to one face's landmarks in an image of ``width`` x
    ``height`` pixels (see the module's docstring); raises :class:`PoseError`."""
    points = np.asarray(landmarks, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] < MESH_POINTS:
        raise PoseError(f"expected at least {MESH_POINTS} landmarks of 3 values, got "
                        f"{points.shape}")  # fmt: skip
    if not np.all(np.isfinite(points)):
        raise PoseError("landmarks are not finite")
    if width <= 0 or height <= 0:
        raise PoseError(f"image size {width}x{height} is not positive")
    canonical, weights = _canonical()
    left, bottom, x_scale, y_scale = _frustum(width, height)
    screen = points.T.copy()  # 3 x N, all landmarks (the irises ride along)
    screen[1] = 1.0 - screen[1]  # origin at the top-left corner
    screen *= np.array([[x_scale], [y_scale], [x_scale]])
    screen[0] += left
    screen[1] += bottom
    mesh = slice(0, MESH_POINTS)
    depth_offset = float(screen[2, mesh].mean())

    def scale_of(candidate: F64Array) -> float:
        transform = solve_weighted_procrustes(canonical, candidate[:, mesh], weights)
        return float(np.linalg.norm(transform[:3, 0]))

    def unproject(scale: float) -> F64Array:
        out = screen.copy()
        out[2] = (out[2] - depth_offset + NEAR_CM) / scale
        out[0] = out[0] * out[2] / NEAR_CM
        out[1] = out[1] * out[2] / NEAR_CM
        out[2] *= -1.0  # screen space is left-handed, metric space right-handed
        return out

    first = screen.copy()
    first[2] *= -1.0
    first_scale = scale_of(first)
    second_scale = scale_of(unproject(first_scale))
    metric = unproject(first_scale * second_scale)
    transform = solve_weighted_procrustes(canonical, metric[:, mesh], weights)
    scaled = transform[:3, :3]
    scale = float(np.cbrt(np.linalg.det(scaled)))
    u, _s, vt = np.linalg.svd(scaled / scale)
    rotation = u @ vt
    aligned = np.asarray(np.linalg.solve(scaled, metric - transform[:3, 3:4]), np.float64)
    yaw, pitch, roll = yaw_pitch_roll(rotation)
    return Pose(rotation, transform[:3, 3].copy(), scale, yaw, pitch, roll, aligned.T)


def canonical_landmarks(width: int = 640, height: int = 480, distance_cm: float = 50.0,
                        rotation: F64Array | None = None) -> F64Array:  # fmt: skip
    """The canonical face as a face mesh would see it: 468 landmarks projected by
    MediaPipe's camera from ``distance_cm`` in front of it, turned by ``rotation``
    (identity: looking into the camera). The inverse of :func:`fit_pose` for a rigid face,
    used by the tests and to seed the neutral face."""
    canonical, _weights = _canonical()
    turned = (np.eye(3) if rotation is None else rotation) @ canonical
    camera = turned + np.array([[0.0], [0.0], [-distance_cm]])
    left, bottom, x_scale, y_scale = _frustum(width, height)
    depth = -camera[2]
    near_x = camera[0] * NEAR_CM / depth
    near_y = camera[1] * NEAR_CM / depth
    x = (near_x - left) / x_scale
    y = 1.0 - (near_y - bottom) / y_scale
    # MediaPipe's z: relative depth (closer is smaller) on the scale of x, i.e. the
    # width of the near plane at the face's distance.
    z = (depth - depth.mean()) * NEAR_CM / (x_scale * depth.mean())
    return np.stack([x, y, z], axis=1)
