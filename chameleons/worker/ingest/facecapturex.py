"""FaceCaptureX TCP text stream (protocols.md section 3): stream splitting and frame parsing.

A frame is UTF-8 text ending in a single ``a``; a lone ``z`` at a frame boundary ends the
stream. Fields are separated by ``~`` and numbers inside a field by ``:``::

    [timestamp~] camera 4x4 (16 numbers, column by column) ~ face anchor 4x4 (same)
    [~ x:y:z mesh vertices ...] ~ rawName:value ~ rawName:value ... a

Blendshape names contain ``a`` too, so the stream is split structurally: the terminator is
the ``a`` right after a *value*, i.e. after ``:`` and a number (``nan``/``inf`` included so a
broken value still ends its frame and the frame is dropped as non-finite).

Head rotation is ``inverse(camera) @ face``, decomposed with the convention of
:mod:`chameleons.worker.ingest.rotation`: yaw about +y (left/right), pitch about +x, roll
about +z, in degrees, in the ARKit face frame (+x viewer's right, +y up, +z out of the face).
The optional leading timestamp: the public app (github.com/elishahung/FaceCaptureX,
``Extensions.swift`` ``CaptureData.str``) sends none (camera ~ face ~ vertices ~
blendshapes, one frame per ``ARSession`` update); the study's modified app added one, and
its source is not public. So a leading field with a single number is a timestamp, read as
seconds on the sender's clock (``ARFrame.timestamp`` or ``Date().timeIntervalSince1970``),
or as Unix milliseconds when above 1e11 (1e11 ms is 1973, 1e11 s the year 5138, so the
two cannot be confused). Only the differences between timestamps matter (the receiver's
clock aligner maps them onto its own clock); a sender counting milliseconds since boot
would be read as seconds, and the aligner then restarts on every frame, which shows as
capture time = receive time. Without a timestamp the capture time is the receive time.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from chameleons.worker.frames import (
    BLENDSHAPE_INDEX,
    N_BLENDSHAPES,
    FaceFrame,
    canonical_name,
    ignored_name,
    zeros,
)
from chameleons.worker.ingest.errors import IngestError
from chameleons.worker.ingest.livelink import clamp_blendshapes
from chameleons.worker.ingest.rotation import F64Array, yaw_pitch_roll

DEFAULT_MAX_FRAME_BYTES = 256 * 1024  # a frame with the full 1220-vertex mesh is ~40-50 KB
SOURCE = "facecapturex"
_NUMBER = re.compile(rb"[-+]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|nan|inf)", re.IGNORECASE)
_VALUE_WINDOW = 48  # longest number token we accept before a terminator, plus its ':'
_WHITESPACE = b" \t\r\n"
_NUMERIC_START = frozenset("0123456789-+.")
_MS_THRESHOLD = 1e11


class FaceCaptureXDecoder:
    """Incremental splitter: feed raw TCP reads, get complete frames (without the ``a``).

    Frames longer than ``max_frame_bytes`` are dropped (``oversized`` counts them) and the
    decoder resynchronises on the next terminator. After a lone ``z`` ``ended`` is True and
    further input is ignored.
    """

    def __init__(self, max_frame_bytes: int = DEFAULT_MAX_FRAME_BYTES) -> None:
        self.max_frame_bytes = max_frame_bytes
        self.ended = False
        self.oversized = 0
        self._buf = bytearray()
        self._checked = 0  # every 'a' before this index is known not to be a terminator
        self._discarding = False  # inside an oversized frame, dropping until its end

    def feed(self, data: bytes) -> list[bytes]:
        if self.ended:
            return []
        self._buf += data
        frames: list[bytes] = []
        while not self._at_stream_end():
            end = self._find_terminator()
            if end < 0:
                self._limit_buffer()
                break
            frame = bytes(self._buf[:end])
            del self._buf[: end + 1]
            self._checked = 0
            if self._discarding or len(frame) > self.max_frame_bytes:
                self.oversized += 0 if self._discarding else 1
                self._discarding = False
                continue
            frames.append(frame)
        return frames

    @property
    def pending_bytes(self) -> int:
        return len(self._buf)

    def _at_stream_end(self) -> bool:
        if self._discarding or self._checked:
            return False
        stripped = self._buf.lstrip(_WHITESPACE)
        if len(stripped) != len(self._buf):
            self._buf = bytearray(stripped)
        if self._buf[:1] == b"z":
            self.ended = True
            self._buf.clear()
        return self.ended

    def _find_terminator(self) -> int:
        buf = self._buf
        pos = buf.find(b"a", self._checked)
        while pos >= 0:
            if self._ends_value(pos):
                return pos
            pos = buf.find(b"a", pos + 1)
        self._checked = len(buf)
        return -1

    def _ends_value(self, pos: int) -> bool:
        window = bytes(self._buf[max(0, pos - _VALUE_WINDOW) : pos])
        cut = max(window.rfind(b":"), window.rfind(b"~"))
        if cut < 0 or window[cut] != ord(":"):
            return False
        return _NUMBER.fullmatch(window, cut + 1) is not None

    def _limit_buffer(self) -> None:
        if not self._discarding and len(self._buf) <= self.max_frame_bytes:
            return
        if not self._discarding:
            self.oversized += 1
            self._discarding = True
        # Only the tail can still hold the start of the terminating value.
        del self._buf[:-_VALUE_WINDOW]
        self._checked = len(self._buf)


@dataclass(frozen=True, slots=True)
class FaceCaptureXParse:
    frame: FaceFrame
    unknown_names: tuple[str, ...]
    bad_fields: int  # fields that could not be read and were skipped
    vertices: int


def _floats(field: str, what: str) -> list[float]:
    try:
        return [float(x) for x in field.split(":")]
    except ValueError as exc:
        raise IngestError("bad_transform", f"{what}: {exc}") from exc


def _transform(fields: list[str], index: int, what: str) -> F64Array:
    if index >= len(fields):
        raise IngestError("missing_transform", f"no {what} transform")
    numbers = _floats(fields[index], what)
    if len(numbers) != 16:
        raise IngestError("bad_transform", f"{what} transform has {len(numbers)} numbers")
    if not all(math.isfinite(x) for x in numbers):
        raise IngestError("non_finite", f"{what} transform")
    return np.array(numbers, dtype=np.float64).reshape(4, 4, order="F")


def head_rotation(camera: F64Array, face: F64Array) -> tuple[float, float, float]:
    """Yaw, pitch, roll (degrees) of the face relative to the camera."""
    try:
        relative = np.linalg.solve(camera, face)  # inverse(camera) @ face
    except np.linalg.LinAlgError as exc:
        raise IngestError("bad_transform", "singular camera transform") from exc
    u, scale, vt = np.linalg.svd(relative[:3, :3])
    if not np.all(np.abs(scale - 1.0) < 0.05) or np.linalg.det(u @ vt) < 0:
        raise IngestError("bad_transform", "not a rotation")
    return yaw_pitch_roll(u @ vt)  # nearest exact rotation: removes float32 rounding


def _timestamp(field: str) -> float | None:
    if ":" in field or not field or field[0] not in _NUMERIC_START:
        return None
    try:
        value = float(field)
    except ValueError:
        return None
    if not math.isfinite(value):
        raise IngestError("non_finite", "timestamp")
    return value / 1000.0 if abs(value) > _MS_THRESHOLD else value


def parse_facecapturex_frame(data: bytes | str, *, receive_time: float) -> FaceCaptureXParse:
    """One frame's text (with or without its final ``a``) -> FaceFrame, or IngestError."""
    try:
        text = data.decode("utf-8") if isinstance(data, bytes | bytearray) else data
    except UnicodeDecodeError as exc:
        raise IngestError("bad_encoding", str(exc)) from exc
    text = text.strip()
    text = text.removesuffix("a")
    fields = [f.strip() for f in text.split("~")]
    fields = [f for f in fields if f]
    timestamp = _timestamp(fields[0]) if fields else None
    first = 0 if timestamp is None else 1
    camera = _transform(fields, first, "camera")
    face = _transform(fields, first + 1, "face anchor")
    yaw, pitch, roll = head_rotation(camera, face)
    values = zeros(N_BLENDSHAPES)
    seen, unknown, bad, vertices = 0, [], 0, 0
    for field in fields[first + 2 :]:
        if field[0] in _NUMERIC_START:
            vertices += 1
            continue
        tokens = field.split(":")
        if len(tokens) % 2:
            bad += 1
            continue
        for name, raw in zip(tokens[::2], tokens[1::2], strict=True):
            try:
                value = float(raw)
            except ValueError:
                bad += 1
                continue
            if not math.isfinite(value):
                raise IngestError("non_finite", f"blendshape {name}")
            canonical = canonical_name(name)
            if canonical is None:
                if not ignored_name(name):
                    unknown.append(name)
                continue
            values[BLENDSHAPE_INDEX[canonical]] = value
            seen += 1
    if not seen:
        raise IngestError("no_blendshapes", "no known blendshape in the frame")
    frame = FaceFrame(
        capture_time=receive_time if timestamp is None else timestamp,
        receive_time=receive_time,
        blendshapes=clamp_blendshapes(values),
        head=np.array([yaw, pitch, roll], dtype=np.float32),
        source=SOURCE,
    )
    return FaceCaptureXParse(frame, tuple(unknown), bad, vertices)
