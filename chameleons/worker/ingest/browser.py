"""The capture page's webcam as a capture source of the worker (``webcam-browser``).

The capture page (``/capture/<booth>/<key>``) runs MediaPipe's face mesh in the browser and
sends each frame's landmarks to the server over its WebSocket; the server maps the page's
capture times onto its own clock and relays the frames to the booth's worker over the
command link (topic :data:`CAPTURE_TOPIC`, no acks: a late frame is a lost frame). Here
they become :class:`FaceFrame` s through the same :class:`LandmarkMapper` as the worker's
own camera (one implementation of pose, features and the ARKit mapping; the booth's
calibration and iPhone-taught map apply alike) and are published like Live Link's and
FaceCaptureX's frames: same pairing of the participant topic, stats, fps chip, no-face
counting, recordings.

Messages (envelopes of topic ``capture``, sent by ``chameleons.backend.capture.relay``):

- ``landmarks``: body ``capture_time`` and ``sent`` (the server's monotonic clock: when the
  camera took the frame, when the server relayed it), ``width``/``height`` (the video's
  pixels); payload the landmarks as float32 ``x, y, z`` rows (468 or 478 of them);
- ``no_face``: body ``capture_time``, ``sent``: the page's tracker found no face;
- ``status`` (about once a second and on changes): body ``connected`` (the page is open),
  ``brightness`` (mean 8-bit luma, or null), ``problem`` (``camera busy``, ``camera
  denied``, ``no camera``... or null), ``camera`` (the camera's label).

The worker's clock and the server's are the same when both run on one computer (the
demo, most booths); otherwise the worker keeps the page's capture-to-relay age and the
relay's own latency (well under a millisecond on a LAN) goes uncounted.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any, Final

import numpy as np
import zmq

from chameleons.worker.envelope import Message
from chameleons.worker.ingest.receivers import PARTICIPANT_TOPIC, FramePublisher
from chameleons.worker.ingest.stats import CaptureStats
from chameleons.worker.ingest.transform import FrameTransform
from chameleons.worker.ingest.webcam import BROWSER_SOURCE, DARK_LEVEL, LandmarkMapper

log = logging.getLogger(__name__)
CAPTURE_TOPIC: Final = "capture"
LANDMARKS, NO_FACE, STATUS = "landmarks", "no_face", "status"
MAX_QUEUE = 64  # frames waiting for the mapper; more means the worker cannot keep up
MAX_LANDMARKS = 478
_STOP = object()


class BrowserReceiver:
    """Maps and publishes the capture page's frames on a thread of its own; the control
    hub hands it the relayed envelopes (:meth:`offer`)."""

    kind = "webcam-browser"

    def __init__(
        self, *, publish_endpoint: str, context: zmq.Context[zmq.Socket[bytes]] | None = None,
        transform: FrameTransform | None = None, topic: str = PARTICIPANT_TOPIC,
        mapper: LandmarkMapper | None = None, clock: Callable[[], float] = time.monotonic,
    ) -> None:  # fmt: skip
        self.port = 0
        self.transform = transform or FrameTransform()
        self.mapper = mapper or LandmarkMapper()
        self.stats = CaptureStats(clock)
        self._clock = clock
        self._publisher_args = (context or zmq.Context.instance(), publish_endpoint, topic)
        self._queue: queue.Queue[Any] = queue.Queue(MAX_QUEUE)
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self.brightness: float | None = None
        self.camera = ""
        self.head: tuple[float, float, float] | None = None  # the last face, as the camera saw it

    def start(self) -> BrowserReceiver:
        if self._thread is not None:
            raise RuntimeError("browser capture receiver already started")
        self._thread = threading.Thread(target=self._run, name="ingest-browser", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 5.0) -> None:
        if self._thread is None:
            return
        with contextlib.suppress(queue.Full):
            self._queue.put(_STOP, timeout=timeout)
        self._thread.join(timeout)
        if self._thread.is_alive():
            raise RuntimeError(f"browser capture receiver did not stop within {timeout} s")

    def offer(self, message: Message) -> None:
        """Take one relayed envelope (any thread; never blocks)."""
        if message.type == STATUS:
            self._status(message.body)
            return
        try:
            self._queue.put_nowait(message)
        except queue.Full:
            self.stats.count_drop("queue_full")

    def calibrate(self, body: Mapping[str, Any]) -> dict[str, Any]:
        """The page's neutral-face step: ``action`` ``start`` collects, ``finish`` takes the
        neutral face from what was collected (the command ``calibrate_webcam``)."""
        action = body.get("action")
        if action == "start":
            self.mapper.start_neutral()
            return {"collecting": True}
        if action == "finish":
            return self.mapper.finish_neutral()
        return {"calibrated": False, "problem": f"unknown calibration step {action!r}"}

    def _status(self, body: Mapping[str, Any]) -> None:
        connected = bool(body.get("connected"))
        if connected != self.stats.connected:
            self.stats.set_connected(connected)
        level = body.get("brightness")
        with self._lock:
            self.brightness = float(level) if isinstance(level, int | float) else None
            self.camera = str(body.get("camera") or "")[:200]
        problem = body.get("problem")
        if isinstance(problem, str) and problem:
            self.stats.set_problem(problem[:200])
        elif self.brightness is not None and self.brightness < DARK_LEVEL:
            self.stats.set_problem(f"too dark for the camera to see a face well (brightness "
                                   f"{self.brightness:.0f} of 255): light the face")  # fmt: skip

    def _run(self) -> None:
        context, endpoint, topic = self._publisher_args
        publisher = FramePublisher(context, endpoint, topic=topic, source="ingest.browser")
        try:
            while True:
                message = self._queue.get()
                if message is _STOP:
                    break
                try:
                    self._frame(publisher, message)
                except Exception:  # one bad frame never ends the capture
                    self.stats.count_drop("internal_error")
                    log.exception("browser capture frame failed (counted, carrying on)")
        finally:
            publisher.close()

    def _capture_time(self, body: Mapping[str, Any], now: float) -> float:
        """The capture time on this worker's clock: now minus the frame's age at relay."""
        age = float(body["sent"]) - float(body["capture_time"])
        return now - max(0.0, age)

    def _frame(self, publisher: FramePublisher, message: Message) -> None:
        now = self._clock()
        body = message.body
        try:
            capture_time = self._capture_time(body, now)
        except (KeyError, TypeError, ValueError):
            self.stats.count_drop("bad_times")
            return
        if message.type == NO_FACE:
            self.stats.count_no_face(now)
            return
        if message.type != LANDMARKS:
            self.stats.count_drop("unknown_type")
            return
        points = message.array()
        width, height = body.get("width"), body.get("height")
        if (points.size % 3 or not 468 * 3 <= points.size <= MAX_LANDMARKS * 3
                or not isinstance(width, int) or not isinstance(height, int)):  # fmt: skip
            self.stats.count_drop("bad_landmarks")
            return
        try:
            frame = self.mapper.frame(points.reshape(-1, 3), width, height,
                                      capture_time=capture_time, receive_time=now,
                                      source=BROWSER_SOURCE)  # fmt: skip
        except ValueError:  # landmarks no pose fits: as good as no face
            self.stats.count_no_face(now)
            return
        head = tuple(float(a) for a in frame.head)
        with self._lock:
            self.head = (head[0], head[1], head[2])
        frame = self.transform.apply(frame)
        yaw = -float(frame.head[0]) if self.transform.mirror else float(frame.head[0])
        self.stats.note_head(frame.receive_time, yaw, float(frame.head[1]))
        publisher.publish(frame)
        self.stats.count_frame(frame.receive_time)

    def snapshot(self) -> dict[str, Any]:
        with self._lock:
            head = None if self.head is None else [round(a, 2) for a in self.head]
            brightness, camera = self.brightness, self.camera
        return {**self.stats.snapshot(), **self.mapper.snapshot(), "brightness": brightness,
                "camera": camera, "head": head, "source": BROWSER_SOURCE}  # fmt: skip


def landmark_payload(points: np.ndarray) -> bytes:
    """Landmarks (N x 3) as the ``landmarks`` message's payload."""
    return np.asarray(points, dtype="<f4").reshape(-1).tobytes()
