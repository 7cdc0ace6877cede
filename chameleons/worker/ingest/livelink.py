"""Live Link Face UDP packets (version 6, big-endian; protocols.md section 2a) -> FaceFrame.

Packet layout::

    uint8   version (= 6)
    int32   device id length L1, then L1 bytes UTF-8
    int32   subject name length L2, then L2 bytes UTF-8
    int32   frame number      float32 subframe
    int32   frame rate numerator, int32 denominator
    uint8   value count (= 61), then 61 float32: 52 blendshapes, HeadYaw, HeadPitch, HeadRoll,
            LeftEyeYaw, LeftEyePitch, LeftEyeRoll, RightEyeYaw, RightEyePitch, RightEyeRoll

Blendshapes are clamped to 0..1 (devices send tiny negatives and denormals); head and eye
rotations are signed and never clamped.

Rotation unit (setting ``livelink_rotation_scale``; docs/livelink.md has the evidence). The
app sends **radians**: every public recording of its stream and its CSV takes only makes
sense that way (a head roll of 24.5 degrees and eye yaw of +-34 degrees as radians, 77 and
+-109 degrees read as degrees/180). Unreal's own ARKit plugin (``AppleARKitFaceSupport``,
an Unreal app running on the phone, e.g. the Face AR Sample) maps degrees to -1..1 by
dividing by 180 instead. The setting names the unit:

- ``"radians"`` (default): degrees = value * 180 / pi (the Live Link Face app);
- ``"degrees/180"``: degrees = value * 180 (an Unreal app's own remote publisher);
- ``"degrees"``: the value is already degrees;
- a number: degrees = value * that factor.

Checking it: the booth check's "turn your head left, then nod" step shows the measured yaw
and pitch; a turn of about 45 degrees must read about 45.

Packets the receiver tells apart (Unreal's receiver, ``FAppleARKitLiveLinkRemoteListener``,
ignores a packet no longer than its minimum size and reads the values without looking at
what follows them; the newer ``LiveLinkFace`` plugin reads the MetaHuman Animator stream):

- a header that ends after the frame rate, or after a value count of 0: the phone sees
  no face (``no_face``, not an error);
- bytes after the 61 values: accepted, as Unreal's receiver does;
- the MetaHuman Animator stream (little-endian ``uint16`` version and subject id length,
  ``uint16`` control values scaled by 65535, six head-pose floats): refused with
  :data:`METAHUMAN_MESSAGE`.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import numpy as np

from chameleons.worker.frames import N_BLENDSHAPES, F32Array, FaceFrame
from chameleons.worker.ingest.errors import IngestError

LIVELINK_VERSION = 6
LIVELINK_VALUE_COUNT = 61
MAX_NAME_BYTES = 256  # device ids are 36-byte UUIDs and subject names are short
MAX_PACKET_BYTES = 2048  # 306 + L2 for a UUID device id; anything far beyond is not Live Link
_BE_F32 = np.dtype(">f4")
_TINY = float(np.finfo(np.float32).tiny)
SOURCE = "livelink"


def rotation_factor(scale: str | float) -> float:
    """Degrees per wire unit for a ``livelink_rotation_scale`` setting value."""
    if isinstance(scale, int | float):
        factor = float(scale)
    else:
        named = {"degrees/180": 180.0, "radians": 180.0 / math.pi, "degrees": 1.0}
        text = scale.strip().lower()
        try:
            factor = named[text] if text in named else float(text)
        except ValueError as exc:
            raise ValueError(f"unknown Live Link rotation scale {scale!r}") from exc
    if not math.isfinite(factor) or factor == 0:
        raise ValueError(f"Live Link rotation scale must be a finite non-zero factor: {scale!r}")
    return factor


DEFAULT_ROTATION_SCALE = "radians"
DEFAULT_ROTATION_FACTOR = rotation_factor(DEFAULT_ROTATION_SCALE)
METAHUMAN_MESSAGE = (
    "the phone streams MetaHuman Animator data: in Live Link Face choose the Live Link "
    "(ARKit) mode instead of MetaHuman Animator"
)
NO_FACE, METAHUMAN = "no_face", "metahuman_stream"


@dataclass(frozen=True, slots=True)
class LiveLinkPacket:
    """A decoded packet, values still in wire units."""

    device_id: str
    subject: str
    frame_number: int
    subframe: float
    rate_numerator: int
    rate_denominator: int
    values: F32Array  # 61 values in wire order

    def capture_time(self) -> float | None:
        """Seconds on the sender's timecode clock, or None when the timing is not sensible."""
        num, den = self.rate_numerator, self.rate_denominator
        if num <= 0 or den <= 0 or not 1 <= num / den <= 1000:
            return None
        if self.frame_number < 0 or not 0.0 <= self.subframe < 1.0:
            return None
        return (self.frame_number + self.subframe) * den / num


class _Reader:
    def __init__(self, data: bytes) -> None:
        self.data, self.pos = data, 0

    def take(self, fmt: str) -> tuple[int | float, ...]:
        size = struct.calcsize(fmt)
        if self.pos + size > len(self.data):
            raise IngestError(
                "truncated", f"packet ends at byte {len(self.data)}, needs {self.pos + size}"
            )
        values = struct.unpack_from(fmt, self.data, self.pos)
        self.pos += size
        return values

    def text(self) -> str:
        (length,) = self.take(">i")
        if not 0 <= int(length) <= MAX_NAME_BYTES:
            raise IngestError("bad_length", f"string length {length}")
        end = self.pos + int(length)
        if end > len(self.data):
            raise IngestError(
                "truncated", f"string runs past the packet end ({end} > {len(self.data)})"
            )
        raw, self.pos = self.data[self.pos : end], end
        return raw.decode("utf-8", errors="replace")


def decode_livelink_packet(data: bytes) -> LiveLinkPacket:
    """Decode one datagram; raises :class:`IngestError` with a specific reason (``no_face``
    for a header-only packet, ``metahuman_stream`` for the MetaHuman Animator stream)."""
    if len(data) > MAX_PACKET_BYTES:
        raise IngestError("oversized", f"{len(data)} bytes")
    try:
        return _decode_arkit(bytes(data))
    except IngestError as exc:
        if exc.reason != NO_FACE and is_metahuman_packet(data):
            raise IngestError(METAHUMAN, METAHUMAN_MESSAGE) from None
        raise


def _decode_arkit(data: bytes) -> LiveLinkPacket:
    reader = _Reader(data)
    (version,) = reader.take(">B")
    if version != LIVELINK_VERSION:
        raise IngestError("wrong_version", f"packet version {version}")
    device_id, subject = reader.text(), reader.text()
    frame_number, subframe, num, den = reader.take(">ifii")
    if reader.pos == len(data):
        raise IngestError(NO_FACE, "header only: the phone sees no face")
    (count,) = reader.take(">B")
    if count == 0 and reader.pos == len(data):
        raise IngestError(NO_FACE, "no values: the phone sees no face")
    if count != LIVELINK_VALUE_COUNT:
        raise IngestError("bad_count", f"{count} values, expected {LIVELINK_VALUE_COUNT}")
    needed = reader.pos + 4 * LIVELINK_VALUE_COUNT
    if len(reader.data) < needed:
        raise IngestError("truncated", f"{len(reader.data)} bytes, needs {needed}")
    # Bytes after the values are ignored, as Unreal's receiver ignores them.
    values = np.frombuffer(reader.data, _BE_F32, LIVELINK_VALUE_COUNT, reader.pos)
    if not (np.all(np.isfinite(values)) and math.isfinite(float(subframe))):
        raise IngestError("non_finite", "NaN or infinity in the values")
    return LiveLinkPacket(
        device_id, subject, int(frame_number), float(subframe), int(num), int(den),
        values.astype(np.float32),
    )  # fmt: skip


def is_metahuman_packet(data: bytes) -> bool:
    """Whether ``data`` is exactly one packet of the MetaHuman Animator stream (Unreal's
    ``FLiveLinkFacePacket::Read``: ``uint16`` version, ``uint16`` subject id length and the
    id, frame number/subframe/rate, ``uint16`` count and that many ``uint16`` control
    values, six ``float`` head-pose values; Unreal archives are little-endian)."""
    try:
        _version, length = struct.unpack_from("<HH", data, 0)
        pos = 4 + length
        _frame, _sub, num, den, count = struct.unpack_from("<ifiiH", data, pos)
    except struct.error:
        return False
    pos += struct.calcsize("<ifiiH")
    sizes_fit = pos + 2 * int(count) + 4 * 6 == len(data)
    return bool(0 < length <= MAX_NAME_BYTES and num > 0 and den > 0 and count > 0 and sizes_fit)


def clamp_blendshapes(values: F32Array) -> F32Array:
    """Clamp to 0..1 and flush denormals to zero (they slow every later multiply)."""
    clipped = np.clip(values.astype(np.float32), 0.0, 1.0)
    clipped[clipped < _TINY] = 0.0
    return clipped


def packet_frame(
    packet: LiveLinkPacket, *, receive_time: float, rotation_factor: float = DEFAULT_ROTATION_FACTOR
) -> FaceFrame:
    """The packet as a FaceFrame: blendshapes clamped, rotations converted to degrees."""
    values = packet.values
    capture = packet.capture_time()
    with np.errstate(over="ignore"):  # an overflow becomes inf and is rejected just below
        rotations = (values[N_BLENDSHAPES:].astype(np.float64) * rotation_factor).astype(np.float32)
    if not np.all(np.isfinite(rotations)):
        raise IngestError("non_finite", "rotation overflows after scaling")
    return FaceFrame(
        capture_time=receive_time if capture is None else capture,
        receive_time=receive_time,
        blendshapes=clamp_blendshapes(values[:N_BLENDSHAPES]),
        head=rotations[:3],
        eyes=rotations[3:],
        source=SOURCE,
    )


def parse_livelink_packet(
    data: bytes, *, receive_time: float, rotation_factor: float = DEFAULT_ROTATION_FACTOR
) -> FaceFrame:
    """One datagram -> FaceFrame, or :class:`IngestError`. ``capture_time`` is the sender's
    timecode clock ((frame number + subframe) / frame rate, seconds since the timecode's
    midnight) when the packet's timing is sensible, else ``receive_time``."""
    packet = decode_livelink_packet(data)
    return packet_frame(packet, receive_time=receive_time, rotation_factor=rotation_factor)
