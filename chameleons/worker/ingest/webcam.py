"""Webcam face capture in the worker: landmarks -> FaceFrames, and the local camera receiver.

:class:`LandmarkMapper` is where every webcam path meets the science of
:mod:`chameleons.facemesh.mapping`: landmarks (from the Python tracker here, or sent by the
capture page) become a :class:`FaceFrame` with the booth's :class:`Calibration` (the
participant's neutral face; an iPhone-taught map where the lab made one), the missing
channels marked, the source and calibration named. A neutral-face calibration collects the
features of the frames between :meth:`LandmarkMapper.start_neutral` and
:meth:`LandmarkMapper.finish_neutral` and takes their medians.

:class:`CameraReceiver` is a capture receiver like the Live Link and FaceCaptureX ones
(same ``stats``, same publishing, same :class:`FrameTransform`) that reads a local camera
(``chameleons worker --camera /dev/video0``) or a video file standing in for one, runs the
tracker and publishes frames of source ``webcam-python``. The booth check's problems come
from here: no face (counted like a phone that sees nobody), a frame too dark to track
(mean brightness below :data:`DARK_LEVEL`), a camera that cannot be opened (busy or
missing).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import numpy.typing as npt
import zmq

from chameleons.facemesh.arkit import neutral_from
from chameleons.facemesh.mapping import Calibration, read_face
from chameleons.worker.frames import FaceFrame
from chameleons.worker.ingest.receivers import PARTICIPANT_TOPIC, FramePublisher
from chameleons.worker.ingest.stats import CaptureStats
from chameleons.worker.ingest.transform import FrameTransform

log = logging.getLogger(__name__)
PYTHON_SOURCE, BROWSER_SOURCE = "webcam-python", "webcam-browser"
DARK_LEVEL = 40.0  # mean 8-bit luma below which a face cannot be tracked reliably
MIN_NEUTRAL_FRAMES = 5


class LandmarkMapper:
    """Thread-safe: one capture thread maps, the control side (re)calibrates."""

    def __init__(self, calibration: Calibration | None = None) -> None:
        self._lock = threading.Lock()
        self.calibration = calibration or Calibration()
        self._collecting: list[npt.NDArray[np.float64]] | None = None

    def frame(self, landmarks: npt.ArrayLike, width: int, height: int, *, capture_time: float,
              receive_time: float, source: str) -> FaceFrame:  # fmt: skip
        """The face of one frame's landmarks; raises ``ValueError`` when they have none."""
        with self._lock:
            calibration = self.calibration
        reading = read_face(landmarks, width, height, calibration)
        with self._lock:
            if self._collecting is not None:
                self._collecting.append(reading.features)
        values = np.nan_to_num(reading.blendshapes.astype(np.float32), nan=0.0)
        return FaceFrame(
            capture_time, receive_time, values, np.array(reading.head, dtype=np.float32),
            reading.eyes.astype(np.float32), source, reading.missing, calibration.label(),
        )  # fmt: skip

    def start_neutral(self) -> None:
        with self._lock:
            self._collecting = []

    def finish_neutral(self) -> dict[str, Any]:
        """Take the neutral face from the frames since :meth:`start_neutral`."""
        with self._lock:
            rows, self._collecting = self._collecting or [], None
            if len(rows) < MIN_NEUTRAL_FRAMES:
                return {"calibrated": False, "frames": len(rows),
                        "problem": f"only {len(rows)} frames with a face: hold still facing "
                                   "the camera and calibrate again"}  # fmt: skip
            self.calibration = Calibration(neutral_from(rows), self.calibration.mapping)
            return {"calibrated": True, "frames": len(rows),
                    "calibration": self.calibration.label()}  # fmt: skip

    def snapshot(self) -> dict[str, Any]:
        with self._lock:
            calibration = self.calibration
            collecting = None if self._collecting is None else len(self._collecting)
        return {"calibration": calibration.label(),
                "neutral": calibration.neutral_calibrated,
                "map": calibration.mapping.name, "collecting": collecting}  # fmt: skip


def brightness(image: npt.NDArray[np.uint8]) -> float:
    """Mean luma (ITU-R BT.601) of a subsample of the frame."""
    sample = image[::8, ::8].astype(np.float32)
    return float((sample @ np.array([0.299, 0.587, 0.114], dtype=np.float32)).mean())


Frames = Callable[[], Iterator[Any]]


class CameraReceiver:
    """The worker's own webcam: camera -> tracker -> mapper -> published FaceFrames."""

    kind = "webcam"

    def __init__(
        self, *, device: str, publish_endpoint: str,
        context: zmq.Context[zmq.Socket[bytes]] | None = None,
        transform: FrameTransform | None = None, topic: str = PARTICIPANT_TOPIC,
        mapper: LandmarkMapper | None = None, frames: Frames | None = None, threads: int = 2,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:  # fmt: skip
        self.device, self.port = device, 0
        self.transform = transform or FrameTransform()
        self.mapper = mapper or LandmarkMapper()
        self.stats = CaptureStats(clock)
        self.threads = threads
        self._clock = clock
        self._frames = frames
        self._publisher_args = (context or zmq.Context.instance(), publish_endpoint, topic)
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None
        self.brightness: float | None = None

    def start(self) -> CameraReceiver:
        if self._thread is not None:
            raise RuntimeError("camera receiver already started")
        from chameleons.facemesh.tracker import FaceTracker

        tracker = FaceTracker(threads=self.threads)  # a missing LiteRT fails here, at start
        context, endpoint, topic = self._publisher_args
        publisher = FramePublisher(context, endpoint, topic=topic, source="ingest.webcam")
        self._thread = threading.Thread(target=self._run, args=(tracker, publisher),
                                        name="ingest-webcam", daemon=True)  # fmt: skip
        self._thread.start()
        return self

    def stop(self, timeout: float = 5.0) -> None:
        if self._thread is None:
            return
        self._stopping.set()
        self._thread.join(timeout)
        if self._thread.is_alive():
            raise RuntimeError(f"webcam receiver did not stop within {timeout} s")

    def _source(self) -> Iterator[Any]:
        if self._frames is not None:
            return self._frames()
        from chameleons.worker.ingest.video import camera_frames

        return camera_frames(self.device)

    def _run(self, tracker: Any, publisher: FramePublisher) -> None:
        from chameleons.worker.ingest.video import VideoError

        try:
            self.stats.set_connected(True)
            for frame in self._source():
                if self._stopping.is_set():
                    break
                try:
                    self._frame(tracker, publisher, frame.image)
                except Exception:  # one bad frame never ends the capture
                    self.stats.count_drop("internal_error")
                    log.exception("webcam frame failed (counted, carrying on)")
        except VideoError as exc:
            self.stats.set_problem(f"camera busy or missing: {exc}")
            log.error("webcam %s: %s", self.device, exc)
        finally:
            self.stats.set_connected(False)
            publisher.close()

    def _frame(self, tracker: Any, publisher: FramePublisher,
               image: npt.NDArray[np.uint8]) -> None:  # fmt: skip
        now = self._clock()
        self.brightness = brightness(image)
        if self.brightness < DARK_LEVEL:  # tracked or not, a face this dark is tracked badly
            level = f"{self.brightness:.0f}"
            self.stats.set_problem(f"too dark for the camera to see a face well (brightness "
                                   f"{level} of 255): light the face")  # fmt: skip
        face = tracker.process(image)
        if face is None:
            self.stats.count_no_face(now)
            return
        try:
            frame = self.mapper.frame(face.landmarks, face.width, face.height, capture_time=now,
                                      receive_time=self._clock(), source=PYTHON_SOURCE)  # fmt: skip
        except ValueError:
            self.stats.count_no_face(now)
            return
        frame = self.transform.apply(frame)
        yaw = -float(frame.head[0]) if self.transform.mirror else float(frame.head[0])
        self.stats.note_head(frame.receive_time, yaw, float(frame.head[1]))
        publisher.publish(frame)
        self.stats.count_frame(frame.receive_time)

    def snapshot(self) -> dict[str, Any]:
        return {**self.stats.snapshot(), "device": self.device, **self.mapper.snapshot(),
                "brightness": self.brightness}  # fmt: skip
