"""Live Link Face v6 parser, against packets assembled straight from protocols.md 2a."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from chameleons.worker.frames import BLENDSHAPE_INDEX
from chameleons.worker.ingest.errors import IngestError
from chameleons.worker.ingest.livelink import (
    decode_livelink_packet,
    is_metahuman_packet,
    parse_livelink_packet,
    rotation_factor,
)
from chameleons.worker.ingest.wire import build_livelink_packet, livelink_values

UUID = b"0C8F1A7E-8D4B-4B9A-9E25-3B1C2D4E5F60"


def table_packet(
    values: list[float],
    *,
    version: int = 6,
    device: bytes = UUID,
    subject: bytes = b"Participant",
    frame: int = 4321,
    subframe: float = 0.5,
    rate: tuple[int, int] = (60, 1),
    count: int | None = None,
) -> bytes:
    """The documented table, field by field, big-endian."""
    parts = [
        struct.pack(">B", version),
        struct.pack(">i", len(device)),
        device,
        struct.pack(">i", len(subject)),
        subject,
        struct.pack(">i", frame),
        struct.pack(">f", subframe),
        struct.pack(">i", rate[0]),
        struct.pack(">i", rate[1]),
        struct.pack(">B", len(values) if count is None else count),
    ]
    parts += [struct.pack(">f", v) for v in values]
    return b"".join(parts)


def sample_values() -> list[float]:
    values = [0.0] * 61
    values[BLENDSHAPE_INDEX["eyeBlinkLeft"]] = 0.75
    values[BLENDSHAPE_INDEX["jawOpen"]] = 0.5
    values[BLENDSHAPE_INDEX["mouthSmileRight"]] = 1.25  # over range: clamped
    values[BLENDSHAPE_INDEX["browInnerUp"]] = -1e-7  # tiny negative: clamped
    values[BLENDSHAPE_INDEX["cheekPuff"]] = 1e-41  # denormal: flushed
    # Head and eyes in radians, the app's unit (docs/livelink.md).
    values[52:55] = [math.radians(d) for d in (45.0, -22.5, 9.0)]
    values[55:61] = [math.radians(d) for d in (18, -18, 0, -36, 36, 1.8)]
    return values


def test_valid_packet_has_the_documented_size_and_values() -> None:
    packet = table_packet(sample_values())
    assert len(packet) == 306 + len(b"Participant")
    frame = parse_livelink_packet(packet, receive_time=10.0)
    assert frame.blendshapes[BLENDSHAPE_INDEX["eyeBlinkLeft"]] == pytest.approx(0.75)
    assert frame.blendshapes[BLENDSHAPE_INDEX["jawOpen"]] == pytest.approx(0.5)
    assert frame.blendshapes[BLENDSHAPE_INDEX["mouthSmileRight"]] == 1.0
    assert frame.blendshapes[BLENDSHAPE_INDEX["browInnerUp"]] == 0.0
    assert frame.blendshapes[BLENDSHAPE_INDEX["cheekPuff"]] == 0.0
    np.testing.assert_allclose(frame.head, [45.0, -22.5, 9.0], rtol=1e-5)
    np.testing.assert_allclose(frame.eyes, [18, -18, 0, -36, 36, 1.8], rtol=1e-5, atol=1e-5)
    assert frame.capture_time == pytest.approx(4321.5 / 60)
    assert frame.receive_time == 10.0
    assert frame.source == "livelink"


def test_rotations_are_signed_and_never_clamped() -> None:
    values = sample_values()
    values[52:55] = [-0.9, 1.5, -2.0]
    frame = parse_livelink_packet(table_packet(values), receive_time=0.0)
    np.testing.assert_allclose(frame.head, np.degrees([-0.9, 1.5, -2.0]), rtol=1e-5)


@pytest.mark.parametrize(
    ("scale", "raw", "degrees"),
    [("degrees/180", 0.25, 45.0), ("radians", math.pi / 4, 45.0), ("degrees", 45.0, 45.0),
     ("90", 0.5, 45.0), (2.0, 22.5, 45.0)],
)  # fmt: skip
def test_rotation_scale_setting(scale: str | float, raw: float, degrees: float) -> None:
    values = sample_values()
    values[52] = raw
    frame = parse_livelink_packet(
        table_packet(values), receive_time=0.0, rotation_factor=rotation_factor(scale)
    )
    assert frame.head[0] == pytest.approx(degrees, rel=1e-5)


@pytest.mark.parametrize("scale", ["furlongs", "0", "nan", "inf"])
def test_bad_rotation_scale_is_refused(scale: str) -> None:
    with pytest.raises(ValueError, match="rotation scale"):
        rotation_factor(scale)


def test_builder_matches_the_table_byte_for_byte() -> None:
    values = sample_values()
    built = build_livelink_packet(
        values, frame_number=4321, subframe=0.5, device_id=UUID.decode(), subject="Participant"
    )
    assert built == table_packet(values)


def test_builder_converts_degrees_with_the_ingest_default() -> None:
    wire = livelink_values(np.zeros(52), head_deg=(45.0, 0.0, -9.0))
    assert wire[52] == pytest.approx(math.pi / 4)  # radians, as the app sends
    frame = parse_livelink_packet(build_livelink_packet(wire), receive_time=0.0)
    np.testing.assert_allclose(frame.head, [45.0, 0.0, -9.0], rtol=1e-5, atol=1e-5)


def test_decoded_packet_keeps_device_and_subject() -> None:
    packet = decode_livelink_packet(table_packet(sample_values(), subject="Bühne".encode()))
    assert packet.device_id == UUID.decode()
    assert packet.subject == "Bühne"
    assert (packet.rate_numerator, packet.rate_denominator) == (60, 1)


def reason(packet: bytes) -> str:
    with pytest.raises(IngestError) as info:
        parse_livelink_packet(packet, receive_time=0.0)
    return info.value.reason


def test_every_truncation_is_reported_as_truncated_except_the_header_only_no_face() -> None:
    packet = table_packet(sample_values())
    header = len(packet) - 1 - 4 * 61  # up to and with the frame rate
    for cut in range(len(packet)):
        assert reason(packet[:cut]) == ("no_face" if cut == header else "truncated"), cut


def test_a_header_only_packet_or_a_zero_count_means_the_phone_sees_no_face() -> None:
    packet = table_packet(sample_values())
    header = packet[: len(packet) - 1 - 4 * 61]
    assert reason(header) == "no_face"
    assert reason(header + b"\x00") == "no_face"


@pytest.mark.parametrize("version", [0, 5, 7, 255])
def test_wrong_version(version: int) -> None:
    assert reason(table_packet(sample_values(), version=version)) == "wrong_version"


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("index", [0, 17, 51, 52, 60])
def test_non_finite_values(bad: float, index: int) -> None:
    values = sample_values()
    values[index] = bad
    assert reason(table_packet(values)) == "non_finite"


def test_non_finite_subframe() -> None:
    assert reason(table_packet(sample_values(), subframe=math.nan)) == "non_finite"


def test_rotation_overflowing_after_scaling_is_non_finite() -> None:
    values = sample_values()
    values[52] = 3e38
    assert reason(table_packet(values)) == "non_finite"


def test_oversized() -> None:
    assert reason(table_packet(sample_values()) + b"\0" * 4096) == "oversized"


def test_trailing_bytes_are_accepted_as_unreals_receiver_does() -> None:
    # FAppleARKitLiveLinkRemoteListener reads the 61 values and never looks past them.
    packet = table_packet(sample_values())
    plain = parse_livelink_packet(packet, receive_time=0.0)
    padded = parse_livelink_packet(packet + b"\0\1\2\3" * 8, receive_time=0.0)
    np.testing.assert_array_equal(plain.to_vector(), padded.to_vector())


@pytest.mark.parametrize("length", [-1, -(2**31), 100_000])
def test_absurd_string_length(length: int) -> None:
    packet = table_packet(sample_values())
    broken = packet[:1] + struct.pack(">i", length) + packet[5:]
    assert reason(broken) == "bad_length"


@pytest.mark.parametrize("count", [0, 52, 60, 62, 255])  # 0 with values after: not no_face
def test_bad_count(count: int) -> None:
    assert reason(table_packet(sample_values(), count=count)) == "bad_count"


@pytest.mark.parametrize(
    ("frame", "subframe", "rate"),
    [(10, 0.0, (0, 1)), (10, 0.0, (60, 0)), (-5, 0.0, (60, 1)), (10, 1.5, (60, 1)),
     (10, 0.0, (-60, 1)), (10, 0.0, (1, 100))],
)  # fmt: skip
def test_capture_time_falls_back_to_receive_time(
    frame: int, subframe: float, rate: tuple[int, int]
) -> None:
    packet = table_packet(sample_values(), frame=frame, subframe=subframe, rate=rate)
    assert parse_livelink_packet(packet, receive_time=77.0).capture_time == 77.0


def test_capture_time_with_a_fractional_rate() -> None:
    packet = table_packet(sample_values(), frame=3000, subframe=0.0, rate=(30000, 1001))
    frame = parse_livelink_packet(packet, receive_time=0.0)
    assert frame.capture_time == pytest.approx(3000 * 1001 / 30000)


def _parses_or_ingest_error(data: bytes) -> None:
    try:
        frame = parse_livelink_packet(data, receive_time=1.0)
    except IngestError as exc:
        reason = exc.reason
        assert reason, "every rejection names its reason"
        return
    assert np.all((frame.blendshapes >= 0) & (frame.blendshapes <= 1))
    assert np.all(np.isfinite(frame.to_vector()))


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=3000))
def test_fuzz_arbitrary_bytes(data: bytes) -> None:
    _parses_or_ingest_error(data)


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_fuzz_mutated_valid_packets(data: st.DataObject) -> None:
    packet = bytearray(table_packet(sample_values()))
    for _ in range(data.draw(st.integers(1, 6))):
        index = data.draw(st.integers(0, len(packet) - 1))
        packet[index] = data.draw(st.integers(0, 255))
    cut = data.draw(st.integers(0, len(packet)))
    _parses_or_ingest_error(bytes(packet[:cut]))


def metahuman_packet(controls: int = 3, subject: bytes = UUID) -> bytes:
    """A MetaHuman Animator stream packet as Unreal's ``FLiveLinkFacePacket::Read`` reads it
    (LiveLinkFace plugin): uint16 version, uint16 subject id length and id, frame number,
    subframe, rate, uint16 count, count uint16 control values, six head-pose floats;
    little-endian, as Unreal archives are."""
    head = struct.pack("<HH", 1, len(subject)) + subject
    timing = struct.pack("<ifiiH", 4321, 0.0, 60, 1, controls)
    values = struct.pack(f"<{controls}H", *range(controls)) + struct.pack("<6f", *[0.0] * 6)
    return head + timing + values


def test_the_metahuman_animator_stream_is_refused_with_what_to_do() -> None:
    with pytest.raises(IngestError) as info:
        parse_livelink_packet(metahuman_packet(), receive_time=0.0)
    assert info.value.reason == "metahuman_stream"
    assert "Live Link (ARKit)" in info.value.detail
    assert is_metahuman_packet(metahuman_packet(controls=250))
    assert not is_metahuman_packet(table_packet(sample_values()))
    assert not is_metahuman_packet(metahuman_packet()[:-1])  # not exactly one packet
    assert reason(metahuman_packet()[:-1]) == "wrong_version"
