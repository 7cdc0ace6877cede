"""The one message envelope of the realtime pipeline and the server bridge.

Multipart ZeroMQ message ``[topic, header, payload]``:
- ``topic``: UTF-8 bytes, used for SUB prefix filtering (e.g. ``b"face.participant"``);
- ``header``: compact JSON object with ``type``, ``seq``, ``source``, ``time`` (the
  sender's ``time.monotonic()``) and ``body`` (small JSON-able fields);
- ``payload``: raw little-endian float32 bytes for bulk arrays (may be empty).

``serialize`` and ``deserialize`` are exact inverses; anything else raises
``EnvelopeError`` so a stage can count the frame and drop it.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from chameleons.worker.frames import N_BLENDSHAPES, F32Array, FaceFrame

_F32 = np.dtype("<f4")
_HEADER_KEYS = frozenset({"type", "seq", "source", "time", "body"})


class EnvelopeError(ValueError):
    """A frame that is not a valid envelope. ``reason`` is a short counter key."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason


@dataclass(frozen=True, slots=True)
class Message:
    topic: str
    type: str
    seq: int = 0
    source: str = ""
    time: float = 0.0
    body: dict[str, Any] = field(default_factory=dict)
    payload: bytes = b""

    def array(self) -> F32Array:
        """The payload as a float32 array (copy, native byte order)."""
        return np.frombuffer(self.payload, dtype=_F32).astype(np.float32)


def serialize(message: Message) -> list[bytes]:
    header = {
        "type": message.type,
        "seq": message.seq,
        "source": message.source,
        "time": message.time,
        "body": message.body,
    }
    encoded = json.dumps(header, separators=(",", ":"), allow_nan=False).encode()
    return [message.topic.encode(), encoded, message.payload]


def deserialize(frames: list[bytes]) -> Message:
    if len(frames) != 3:
        raise EnvelopeError("frame_count", f"expected 3 parts, got {len(frames)}")
    topic_raw, header_raw, payload = frames
    try:
        topic = bytes(topic_raw).decode()
        header = json.loads(bytes(header_raw), parse_constant=_reject_constant)
    except (ValueError, RecursionError) as exc:  # RecursionError: absurdly nested JSON
        raise EnvelopeError("bad_header", str(exc)) from exc
    if not isinstance(header, dict) or set(header) != _HEADER_KEYS:
        raise EnvelopeError("bad_header", "header must have exactly " + ", ".join(_HEADER_KEYS))
    kind, seq, source, when, body = (header[k] for k in ("type", "seq", "source", "time", "body"))
    valid = (
        isinstance(kind, str)
        and isinstance(seq, int)
        and not isinstance(seq, bool)
        and isinstance(source, str)
        and isinstance(when, int | float)
        and not isinstance(when, bool)
        and isinstance(body, dict)
    )
    if not valid:
        raise EnvelopeError("bad_header", "wrong field types")
    payload = bytes(payload)
    if len(payload) % 4:
        raise EnvelopeError("bad_payload", "payload is not whole float32 values")
    return Message(topic, kind, seq, source, float(when), body, payload)


def _reject_constant(name: str) -> float:
    raise ValueError(f"non-finite number {name} in header")


def frame_message(
    frame: FaceFrame, topic: str, *, seq: int, source: str, time: float, type: str = "face"
) -> Message:
    """A face frame as an envelope: times in the header, the 61 values as raw float32."""
    body: dict[str, Any] = {"capture_time": frame.capture_time,
                            "receive_time": frame.receive_time, "frame_source": frame.source}
    if frame.missing:
        body["missing"] = list(frame.missing)
    if frame.calibration:
        body["calibration"] = frame.calibration
    return Message(topic, type, seq, source, time, body, frame.to_vector().astype(_F32).tobytes())


def message_frame(message: Message) -> FaceFrame:
    """Inverse of :func:`frame_message`; raises ``EnvelopeError`` on a malformed frame."""
    body = message.body
    try:
        capture, receive = float(body["capture_time"]), float(body["receive_time"])
        source = str(body.get("frame_source", ""))
        missing = tuple(int(i) for i in body.get("missing", ()))
        calibration = str(body.get("calibration", ""))
    except (KeyError, TypeError, ValueError) as exc:
        raise EnvelopeError("bad_face", "missing frame times") from exc
    if any(not 0 <= i < N_BLENDSHAPES for i in missing):
        raise EnvelopeError("bad_face", "missing channel out of range")
    vector = message.array()
    if vector.shape != (FaceFrame.VECTOR_SIZE,):
        raise EnvelopeError("bad_face", f"face payload has {vector.size} values")
    if not (math.isfinite(capture) and math.isfinite(receive)):
        raise EnvelopeError("bad_face", "non-finite frame times")
    if not np.all(np.isfinite(vector)):
        raise EnvelopeError("bad_face", "non-finite values")
    frame = FaceFrame.from_vector(vector, capture, receive, source)
    frame.missing, frame.calibration = missing, calibration
    return frame
