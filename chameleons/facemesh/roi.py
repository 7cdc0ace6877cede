"""Face detection decoding and the face's region of interest, as MediaPipe's face mesh does.

Pure numpy, no I/O; the model runs in :mod:`chameleons.facemesh.tracker`. Sources (the
MediaPipe graphs and calculators of the version the vendored package was built from):

- ``modules/face_detection/face_detection_short_range.pbtxt`` and ``face_detection.pbtxt``:
  the 128x128 input (the whole image, aspect kept by padding with zeros, values -1..1),
  SSD anchors (``SsdAnchorsCalculator``: 4 layers, strides 8/16/16/16, scales 0.1484375 to
  0.75, offset 0.5, aspect ratio 1 plus an interpolated one, fixed anchor size), decoding
  (``TensorsToDetectionsCalculator``: 16 coordinates, box first, 6 key points, x before y,
  scale 128, scores clipped to +-100 then a sigmoid, at least 0.5) and weighted
  non-maximum suppression (``NonMaxSuppressionCalculator``: IoU 0.3, ``WEIGHTED``);
- ``modules/face_landmark/face_detection_front_detection_to_roi.pbtxt``: the ROI from a
  detection, turned so the line from key point 0 to key point 1 (the eyes) is level
  (``DetectionsToRectsCalculator``), grown 1.5 times and made square on its longer side
  (``RectTransformationCalculator``);
- ``modules/face_landmark/face_landmark_landmarks_to_roi.pbtxt``: the next frame's ROI
  from this frame's landmarks (their bounding box, turned by landmarks 33 -> 133, grown
  the same way);
- ``modules/face_landmark/face_landmark_cpu.pbtxt`` and TensorFlow.js's
  ``face-landmarks-detection`` (``constants.ts``): the landmark model's 192x192 crop of the
  ROI (border replicated, values 0..1), 468 landmarks in crop pixels, a face-presence
  score kept at a sigmoid of at least 0.5.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
import numpy.typing as npt
from scipy import ndimage

F32Array = npt.NDArray[np.float32]
F64Array = npt.NDArray[np.float64]
U8Array = npt.NDArray[np.uint8]

DETECTION_SIZE = 128
LANDMARK_SIZE = 192
MIN_DETECTION_SCORE = 0.5
MIN_SUPPRESSION_IOU = 0.3
SCORE_CLIP = 100.0
ROI_SCALE = 1.5
LEFT_EYE_CORNER, RIGHT_EYE_CORNER = 33, 133  # landmarks_to_roi's rotation vector


@dataclass(frozen=True, slots=True)
class Detection:
    """A detected face in normalised image coordinates: box (centre, size) and 6 key
    points (x, y), score 0..1."""

    score: float
    box: tuple[float, float, float, float]  # x_center, y_center, width, height
    keypoints: F64Array  # 6 x 2


@dataclass(frozen=True, slots=True)
class Rect:
    """A rotated rectangle, normalised by the image's width (x) and height (y); rotation in
    radians, clockwise on the image (y points down)."""

    x_center: float
    y_center: float
    width: float
    height: float
    rotation: float


@cache
def ssd_anchors() -> F64Array:
    """The 896 anchor centres (x, y) of the short-range face detector (fixed size 1)."""
    strides = (8, 16, 16, 16)
    centres: list[tuple[float, float]] = []
    layer = 0
    while layer < len(strides):
        stride, repeats = strides[layer], 0
        while layer < len(strides) and strides[layer] == stride:
            repeats += 2  # aspect ratio 1.0 plus the interpolated scale, per layer
            layer += 1
        size = math.ceil(DETECTION_SIZE / stride)
        for y in range(size):
            for x in range(size):
                centres += [((x + 0.5) / size, (y + 0.5) / size)] * repeats
    anchors = np.array(centres, dtype=np.float64)
    anchors.setflags(write=False)
    return anchors


def letterbox(width: int, height: int) -> tuple[float, float, float]:
    """The square the detector sees: (left, top, side) in image pixels (centred, the
    longer side; the rest is zero padding)."""
    side = float(max(width, height))
    return (width - side) / 2.0, (height - side) / 2.0, side


def decode_detections(
    regressors: npt.ArrayLike, scores: npt.ArrayLike, width: int, height: int
) -> list[Detection]:
    """The detector's raw outputs (896 x 16, 896) -> faces in the image, best first."""
    raw = np.asarray(regressors, dtype=np.float64).reshape(-1, 16)
    logits = np.clip(np.asarray(scores, dtype=np.float64).reshape(-1), -SCORE_CLIP, SCORE_CLIP)
    probability = 1.0 / (1.0 + np.exp(-logits))
    keep = np.flatnonzero(probability >= MIN_DETECTION_SCORE)
    if not keep.size:
        return []
    anchors = ssd_anchors()[keep]
    values = raw[keep] / DETECTION_SIZE
    centres = values[:, 0:2] + anchors
    sizes = values[:, 2:4]
    points = values[:, 4:16].reshape(-1, 6, 2) + anchors[:, None, :]
    left, top, side = letterbox(width, height)
    scale = np.array([side / width, side / height])
    offset = np.array([left / width, top / height])
    faces = [
        Detection(float(probability[k]),
                  _box(centres[i] * scale + offset, sizes[i] * scale),
                  points[i] * scale + offset)
        for i, k in enumerate(keep)
    ]  # fmt: skip
    return weighted_nms(faces)


def _box(centre: F64Array, size: F64Array) -> tuple[float, float, float, float]:
    return float(centre[0]), float(centre[1]), float(size[0]), float(size[1])


def _iou(a: tuple[float, ...], b: tuple[float, ...]) -> float:
    ax0, ay0, ax1, ay1 = a[0] - a[2] / 2, a[1] - a[3] / 2, a[0] + a[2] / 2, a[1] + a[3] / 2
    bx0, by0, bx1, by1 = b[0] - b[2] / 2, b[1] - b[3] / 2, b[0] + b[2] / 2, b[1] + b[3] / 2
    w, h = min(ax1, bx1) - max(ax0, bx0), min(ay1, by1) - max(ay0, by0)
    if w <= 0 or h <= 0:
        return 0.0
    inter = w * h
    return inter / (a[2] * a[3] + b[2] * b[3] - inter)


def weighted_nms(faces: list[Detection]) -> list[Detection]:
    """``NonMaxSuppressionCalculator`` ``WEIGHTED``: each cluster of overlapping faces
    (IoU above 0.3 with the best remaining one) becomes their score-weighted mean, with the
    best one's score."""
    remaining = sorted(faces, key=lambda d: d.score, reverse=True)
    kept: list[Detection] = []
    while remaining:
        best = remaining[0]
        cluster = [d for d in remaining if _iou(best.box, d.box) > MIN_SUPPRESSION_IOU]
        remaining = [d for d in remaining if _iou(best.box, d.box) <= MIN_SUPPRESSION_IOU]
        weights = np.array([d.score for d in cluster])
        total = float(weights.sum())
        box = tuple(float(v) for v in (weights @ np.array([d.box for d in cluster])) / total)
        points = np.tensordot(weights, np.stack([d.keypoints for d in cluster]), 1) / total
        kept.append(Detection(best.score, box, points))  # type: ignore[arg-type]
    return kept


def _normalize_radians(angle: float) -> float:
    return angle - 2 * math.pi * math.floor((angle + math.pi) / (2 * math.pi))


def _grown(box: tuple[float, float, float, float], rotation: float, width: int,
           height: int) -> Rect:  # fmt: skip
    """``RectTransformationCalculator`` with scale 1.5 and ``square_long``."""
    long_side = max(box[2] * width, box[3] * height) * ROI_SCALE
    return Rect(box[0], box[1], long_side / width, long_side / height, rotation)


def _rotation(start: F64Array, end: F64Array, width: int, height: int) -> float:
    """The angle that levels the line ``start`` -> ``end`` (normalised points)."""
    dx, dy = (end[0] - start[0]) * width, (end[1] - start[1]) * height
    return _normalize_radians(-math.atan2(-dy, dx))


def roi_from_detection(face: Detection, width: int, height: int) -> Rect:
    rotation = _rotation(face.keypoints[0], face.keypoints[1], width, height)
    return _grown(face.box, rotation, width, height)


def roi_from_landmarks(landmarks: npt.ArrayLike, width: int, height: int) -> Rect:
    """The next frame's ROI from this frame's (normalised) landmarks."""
    points = np.asarray(landmarks, dtype=np.float64)[:, :2]
    low, high = points.min(axis=0), points.max(axis=0)
    box = _box((low + high) / 2, high - low)
    rotation = _rotation(points[LEFT_EYE_CORNER], points[RIGHT_EYE_CORNER], width, height)
    return _grown(box, rotation, width, height)


def rect_to_image(rect: Rect, width: int, height: int) -> F64Array:
    """The 2x3 affine map from the rect's own normalised coordinates (0..1 across, 0..1
    down) to image pixels (continuous: pixel i covers i..i+1)."""
    c, s = math.cos(rect.rotation), math.sin(rect.rotation)
    w, h = rect.width * width, rect.height * height
    cx, cy = rect.x_center * width, rect.y_center * height
    return np.array([[c * w, -s * h, cx - 0.5 * (c * w - s * h)],
                     [s * w, c * h, cy - 0.5 * (s * w + c * h)]])  # fmt: skip


def sample(image: U8Array, affine: F64Array, size: int, *, replicate: bool) -> F32Array:
    """Bilinear resampling: output pixel (u, v) of a ``size`` square takes the image at
    ``affine @ ((u + 0.5) / size, (v + 0.5) / size, 1)``. Outside the image: the nearest
    edge pixel (``replicate``) or 0 (SciPy's ``map_coordinates``, order 1)."""
    grid = (np.arange(size, dtype=np.float64) + 0.5) / size
    a, b = np.meshgrid(grid, grid)  # a across, b down
    x = affine[0, 0] * a + affine[0, 1] * b + affine[0, 2] - 0.5
    y = affine[1, 0] * a + affine[1, 1] * b + affine[1, 2] - 0.5
    out = np.empty((size, size, image.shape[2]), dtype=np.float32)
    mode = "nearest" if replicate else "constant"
    for channel in range(image.shape[2]):
        ndimage.map_coordinates(image[..., channel], [y, x], output=out[..., channel],
                                order=1, mode=mode, cval=0.0)  # fmt: skip
    return out


def detector_input(image: U8Array) -> F32Array:
    """The 1x128x128x3 detector tensor: the whole image letterboxed, values -1..1."""
    height, width = image.shape[:2]
    left, top, side = letterbox(width, height)
    affine = np.array([[side, 0.0, left], [0.0, side, top]])
    square = sample(image, affine, DETECTION_SIZE, replicate=False)
    return np.asarray(square / 127.5 - 1.0, dtype=np.float32)[None]


def landmark_input(image: U8Array, rect: Rect) -> F32Array:
    """The 1x192x192x3 landmark tensor: the ROI, border replicated, values 0..1."""
    height, width = image.shape[:2]
    crop = sample(image, rect_to_image(rect, width, height), LANDMARK_SIZE, replicate=True)
    return np.asarray(crop / 255.0, dtype=np.float32)[None]


def project_landmarks(raw: npt.ArrayLike, rect: Rect, width: int, height: int) -> F64Array:
    """The model's landmarks (crop pixels, x y z) -> normalised image landmarks, z on the
    scale of x (``LandmarkProjectionCalculator``)."""
    points = np.asarray(raw, dtype=np.float64).reshape(-1, 3) / LANDMARK_SIZE
    affine = rect_to_image(rect, width, height)
    xy = points[:, :2] @ affine[:, :2].T + affine[:, 2]
    z = points[:, 2] * rect.width
    return np.column_stack([xy[:, 0] / width, xy[:, 1] / height, z])
