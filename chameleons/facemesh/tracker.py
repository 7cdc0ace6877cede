"""The Python face tracker: MediaPipe's face mesh models run by LiteRT (``ai-edge-litert``).

Detection -> ROI -> landmarks as MediaPipe's ``FaceLandmarkFrontCpu`` graph does
(:mod:`chameleons.facemesh.roi` has the sources): the short-range detector finds a face
only when none is tracked; while one is, each frame's ROI comes from the previous frame's
landmarks, and a face-presence score below 0.5 drops the track (the next frame detects
again). The models are the vendored package's own files (``face_detection_short_range``
and ``face_landmark``, 468 points; ``face_landmark_with_attention`` needs a custom op
LiteRT lacks), read with :func:`chameleons.facemesh.assets.read_packed`.

One tracker serves one video stream from one thread.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from chameleons.facemesh import roi
from chameleons.facemesh.assets import read_packed

DETECTOR_MODEL = "face_detection_short_range.tflite"
LANDMARK_MODEL = "face_landmark.tflite"
MIN_PRESENCE = 0.5
DEFAULT_THREADS = 2


class TrackerUnavailableError(RuntimeError):
    """LiteRT is not installed (the ``ai-edge-litert`` package)."""


def _interpreter(model: bytes, threads: int) -> Any:
    try:
        from ai_edge_litert.interpreter import Interpreter
    except ImportError as exc:  # a dependency, but say what is missing if it is
        raise TrackerUnavailableError(
            "the Python face tracker needs the ai-edge-litert package (pip install "
            "ai-edge-litert)"
        ) from exc
    interpreter = Interpreter(model_content=model, num_threads=threads)
    interpreter.allocate_tensors()
    return interpreter


class _Model:
    """One LiteRT model: input tensor in, named outputs out."""

    def __init__(self, name: str, threads: int) -> None:
        self.interpreter = _interpreter(read_packed(name), threads)
        self.input = self.interpreter.get_input_details()[0]["index"]
        self.outputs = [d["index"] for d in self.interpreter.get_output_details()]

    def __call__(self, tensor: npt.NDArray[np.float32]) -> list[npt.NDArray[np.float32]]:
        self.interpreter.set_tensor(self.input, tensor)
        self.interpreter.invoke()
        return [self.interpreter.get_tensor(i) for i in self.outputs]


@dataclass(frozen=True, slots=True)
class TrackedFace:
    """One frame's face: 468 normalised landmarks (x, y by the image's width and height,
    z on the scale of x), the presence score, and whether a detection started the track."""

    landmarks: npt.NDArray[np.float64]
    presence: float
    detected: bool
    width: int
    height: int


@dataclass
class Timings:
    """Seconds spent per stage in the last :meth:`FaceTracker.process` (for the bench)."""

    detect: float = 0.0
    detect_invoke: float = 0.0
    landmarks: float = 0.0
    landmarks_invoke: float = 0.0
    extra: dict[str, float] = field(default_factory=dict)


class FaceTracker:
    """``process(rgb_image)`` -> :class:`TrackedFace` or None (no face)."""

    def __init__(self, *, threads: int = DEFAULT_THREADS, static_images: bool = False) -> None:
        self.detector = _Model(DETECTOR_MODEL, threads)
        self.landmarker = _Model(LANDMARK_MODEL, threads)
        self.static_images = static_images  # detect on every frame (unrelated photos)
        self.timings = Timings()
        self._roi: roi.Rect | None = None

    def reset(self) -> None:
        """Forget the tracked face: the next frame starts with a detection."""
        self._roi = None

    def detect(self, image: npt.NDArray[np.uint8]) -> list[roi.Detection]:
        height, width = image.shape[:2]
        started = time.perf_counter()
        tensor = roi.detector_input(image)
        invoked = time.perf_counter()
        regressors, scores = self.detector(tensor)
        self.timings.detect_invoke = time.perf_counter() - invoked
        faces = roi.decode_detections(regressors, scores, width, height)
        self.timings.detect = time.perf_counter() - started
        return faces

    def landmarks(self, image: npt.NDArray[np.uint8], rect: roi.Rect) -> tuple[
            npt.NDArray[np.float64], float]:  # fmt: skip
        """Landmarks in ``rect`` and the face-presence probability."""
        height, width = image.shape[:2]
        started = time.perf_counter()
        tensor = roi.landmark_input(image, rect)
        invoked = time.perf_counter()
        raw, flag = self.landmarker(tensor)
        self.timings.landmarks_invoke = time.perf_counter() - invoked
        presence = float(1.0 / (1.0 + np.exp(-float(np.asarray(flag).reshape(-1)[0]))))
        points = roi.project_landmarks(raw, rect, width, height)
        self.timings.landmarks = time.perf_counter() - started
        return points, presence

    def process(self, image: npt.NDArray[np.uint8]) -> TrackedFace | None:
        """One RGB frame (H x W x 3, uint8) -> the face in it, or None."""
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise ValueError(f"expected an H x W x 3 uint8 RGB image, got {image.shape} "
                             f"{image.dtype}")  # fmt: skip
        height, width = image.shape[:2]
        self.timings = Timings()
        detected = self._roi is None or self.static_images
        if detected:
            faces = self.detect(image)
            if not faces:
                self._roi = None
                return None
            self._roi = roi.roi_from_detection(faces[0], width, height)
        assert self._roi is not None
        points, presence = self.landmarks(image, self._roi)
        if presence < MIN_PRESENCE:
            self._roi = None
            if not detected:  # the tracked face moved away: look for it once more
                return self.process(image)
            return None
        self._roi = roi.roi_from_landmarks(points, width, height)
        return TrackedFace(points, presence, detected, width, height)
