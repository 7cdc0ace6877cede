"""The capture page's WebSocket protocol, and its frames as envelopes for the worker.

Page -> server:

- binary, one face: little-endian float64 ``captured``, ``sent`` (the page's
  ``performance.now()`` in ms: when the camera took the frame, when the page sent it),
  ``width``, ``height`` (the video's pixels), ``count`` (landmarks), then ``count`` x 3
  float32 ``x, y, z`` (MediaPipe's normalised landmarks, 468 or 478);
- text JSON ``{"type": "no_face", "captured": ms, "sent": ms}``: no face in that frame;
- ``{"type": "status", "brightness": 0..255 | null, "problem": text | null, "camera":
  label}`` about once a second: the booth check's "too dark", "camera busy", "camera
  denied" come from here;
- ``{"type": "calibrate", "action": "start" | "finish"}``: the neutral-face step;
- ``{"type": "ping", "t": ms}``.

Server -> page: ``{"type": "hello", "booth"}``, ``{"type": "pong", "t"}``,
``{"type": "relay", "frames", "no_face", "unrelayed", "refused", "worker": bool}`` (once
a second: what arrived, what could not go on, what was malformed, and whether the booth's
worker is connected), ``{"type": "calibration", ...}`` (the worker's answer:
``calibrated``, ``frames``, ``calibration`` or ``problem``).

The page's clock is mapped onto the server's monotonic clock on the send times (the
least-delayed frame sets the offset, :class:`ClockAligner`), and a frame's capture time is
its aligned send time minus the page's own capture-to-send time; the worker gets both the
capture time and the relay time on that clock.
"""

from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass, field
from typing import Any, Final

from chameleons.worker.control import CAPTURE_TOPIC
from chameleons.worker.envelope import Message
from chameleons.worker.ingest.stats import ClockAligner

HEADER: Final = struct.Struct("<5d")
MIN_POINTS, MAX_POINTS = 468, 478
MAX_BINARY = HEADER.size + MAX_POINTS * 3 * 4
MAX_TEXT = 2048
CALIBRATION_ACTIONS: Final = ("start", "finish")


class CaptureProtocolError(ValueError):
    """A message the page should not have sent (counted and dropped)."""


@dataclass
class CaptureLink:
    """One open capture page: its clock mapping and counters."""

    booth: str
    aligner: ClockAligner = field(default_factory=ClockAligner)
    seq: int = 0
    frames: int = 0
    no_face: int = 0
    unrelayed: int = 0
    bad: int = 0

    def _times(self, captured_ms: float, sent_ms: float, now: float) -> dict[str, float]:
        if not (math.isfinite(captured_ms) and math.isfinite(sent_ms)):
            raise CaptureProtocolError("frame times are not finite")
        sent = self.aligner.align(sent_ms / 1000.0, now)
        age = max(0.0, (sent_ms - captured_ms) / 1000.0)
        return {"capture_time": sent - age, "sent": now}

    def _message(self, kind: str, body: dict[str, Any], now: float,
                 payload: bytes = b"") -> Message:  # fmt: skip
        self.seq += 1
        return Message(CAPTURE_TOPIC, kind, self.seq, "capture-page", now, body, payload)

    def landmarks(self, data: bytes, now: float) -> Message:
        if not HEADER.size < len(data) <= MAX_BINARY:
            raise CaptureProtocolError(f"a face frame of {len(data)} bytes")
        captured, sent, width, height, count = HEADER.unpack_from(data)
        if not (MIN_POINTS <= count <= MAX_POINTS and count == int(count)
                and len(data) == HEADER.size + int(count) * 12):  # fmt: skip
            raise CaptureProtocolError("the landmark count does not match the frame")
        if not (0 < width <= 8192 and 0 < height <= 8192):
            raise CaptureProtocolError("the video size is out of range")
        body: dict[str, Any] = self._times(captured, sent, now)
        body.update(width=int(width), height=int(height))
        self.frames += 1
        return self._message("landmarks", body, now, bytes(data[HEADER.size :]))

    def no_face_message(self, message: dict[str, Any], now: float) -> Message:
        captured, sent = _number(message, "captured"), _number(message, "sent")
        self.no_face += 1
        return self._message("no_face", self._times(captured, sent, now), now)

    def status(self, message: dict[str, Any] | None, now: float,
               connected: bool = True) -> Message:  # fmt: skip
        message = message or {}
        problem, camera = message.get("problem"), message.get("camera")
        body = {
            "connected": connected,
            "brightness": _finite_number(message.get("brightness")),
            "problem": problem[:200] if isinstance(problem, str) and problem else None,
            "camera": camera[:200] if isinstance(camera, str) else "",
        }
        return self._message("status", body, now)

    def report(self, worker: bool) -> dict[str, Any]:
        return {"type": "relay", "frames": self.frames, "no_face": self.no_face,
                "unrelayed": self.unrelayed, "refused": self.bad, "worker": worker}  # fmt: skip


def parse_text(text: str) -> dict[str, Any]:
    if len(text) > MAX_TEXT:
        raise CaptureProtocolError("a text message over 2 KB")
    try:
        message = json.loads(text)
    except ValueError as exc:
        raise CaptureProtocolError("not JSON") from exc
    if not isinstance(message, dict) or not isinstance(message.get("type"), str):
        raise CaptureProtocolError("a message without a type")
    if message["type"] == "calibrate" and message.get("action") not in CALIBRATION_ACTIONS:
        raise CaptureProtocolError("calibrate: action is start or finish")
    return message


def _finite_number(value: Any) -> float | None:
    """``value`` as a float when it is a finite JSON number, else None."""
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return None


def _number(message: dict[str, Any], name: str) -> float:
    value = _finite_number(message.get(name))
    if value is None:
        raise CaptureProtocolError(f"{name} is not a number")
    return value
