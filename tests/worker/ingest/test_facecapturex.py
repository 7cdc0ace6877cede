"""FaceCaptureX stream splitting and frame parsing, against text written from protocols.md 3."""

from __future__ import annotations

import contextlib
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from chameleons.worker.frames import BLENDSHAPE_INDEX, BLENDSHAPE_NAMES, swift_raw_name
from chameleons.worker.ingest.errors import IngestError
from chameleons.worker.ingest.facecapturex import (
    FaceCaptureXDecoder,
    parse_facecapturex_frame,
)
from chameleons.worker.ingest.wire import build_facecapturex_frame

D = math.radians


def cols(matrix: np.ndarray) -> str:
    """A 4x4 matrix as the protocol's 16 numbers, column by column."""
    return ":".join(repr(float(matrix[r, c])) for c in range(4) for r in range(4))


def pose(rotation: np.ndarray, translation: tuple[float, float, float]) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rotation, translation
    return m


# Single-axis turns written from their physical meaning (face frame: +x viewer's right,
# +y up, +z out of the face), not from the code's rotation helper.
def turned_yaw(deg: float) -> np.ndarray:  # nose (+z) swings towards +x
    c, s = math.cos(D(deg)), math.sin(D(deg))
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def tipped_pitch(deg: float) -> np.ndarray:  # nose swings down, towards -y
    c, s = math.cos(D(deg)), math.sin(D(deg))
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rolled(deg: float) -> np.ndarray:  # the +x side of the head lifts
    c, s = math.cos(D(deg)), math.sin(D(deg))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


CAMERA = pose(rolled(90) @ turned_yaw(-15), (0.1, 1.2, -0.3))  # world-from-camera, not identity


def frame_text(
    relative: np.ndarray,
    shapes: dict[str, float],
    *,
    timestamp: str | None = None,
    mesh: int = 0,
    camera: np.ndarray = CAMERA,
) -> bytes:
    face = camera @ pose(relative, (0.01, -0.02, -0.4))
    fields = ([timestamp] if timestamp else []) + [cols(camera), cols(face)]
    fields += [f"{0.001 * i}:{-0.002 * i}:{0.05 + 1e-5 * i}" for i in range(mesh)]
    fields += [f"{name}:{value}" for name, value in shapes.items()]
    return ("~".join(fields) + "a").encode()


SHAPES = {"mouthSmile_R": 0.5, "eyeBlink_L": 0.25, "jawOpen": 0.75, "cheekSquint_L": 1.5,
          "browInnerUp": -0.01, "mouthLeft": 0.125, "noseSneer_R": 1e-05}  # fmt: skip


def parse(data: bytes) -> np.ndarray:
    return parse_facecapturex_frame(data, receive_time=3.0).frame.head


@pytest.mark.parametrize(
    ("relative", "expected"),
    [(turned_yaw(30), (30, 0, 0)), (turned_yaw(-50), (-50, 0, 0)), (tipped_pitch(20), (0, 20, 0)),
     (tipped_pitch(-35), (0, -35, 0)), (rolled(10), (0, 0, 10)), (rolled(-25), (0, 0, -25)),
     (turned_yaw(20) @ tipped_pitch(-10) @ rolled(5), (20, -10, 5))],
)  # fmt: skip
def test_head_rotation_convention(relative: np.ndarray, expected: tuple[float, ...]) -> None:
    np.testing.assert_allclose(parse(frame_text(relative, SHAPES)), expected, atol=1e-3)


def test_blendshapes_by_swift_name_in_any_order_clamped() -> None:
    parsed = parse_facecapturex_frame(frame_text(np.eye(3), SHAPES), receive_time=3.0)
    shapes = parsed.frame.blendshapes
    assert shapes[BLENDSHAPE_INDEX["mouthSmileRight"]] == 0.5
    assert shapes[BLENDSHAPE_INDEX["eyeBlinkLeft"]] == 0.25
    assert shapes[BLENDSHAPE_INDEX["jawOpen"]] == 0.75
    assert shapes[BLENDSHAPE_INDEX["cheekSquintLeft"]] == 1.0
    assert shapes[BLENDSHAPE_INDEX["browInnerUp"]] == 0.0
    assert shapes[BLENDSHAPE_INDEX["mouthLeft"]] == 0.125
    assert shapes[BLENDSHAPE_INDEX["noseSneerRight"]] == pytest.approx(1e-5)
    assert shapes[BLENDSHAPE_INDEX["tongueOut"]] == 0.0  # missing is fine
    assert parsed.frame.capture_time == parsed.frame.receive_time == 3.0
    assert parsed.frame.source == "facecapturex"
    assert parsed.unknown_names == ()
    assert parsed.vertices == 0


def test_mesh_timestamp_and_unknown_names() -> None:
    # MediaPipe's "_neutral" category is dropped by name, never counted as unknown.
    shapes = {**SHAPES, "browFurrow_L": 0.3, "hatBrim": 0.9, "_neutral": 0.99}
    data = frame_text(turned_yaw(12), shapes, timestamp="1712345678.25", mesh=1220)
    assert len(data) > 30_000
    parsed = parse_facecapturex_frame(data, receive_time=3.0)
    assert parsed.vertices == 1220
    assert parsed.frame.capture_time == 1712345678.25
    assert sorted(parsed.unknown_names) == ["browFurrow_L", "hatBrim"]
    assert parsed.frame.head[0] == pytest.approx(12, abs=1e-3)


def test_millisecond_timestamp() -> None:
    data = frame_text(np.eye(3), SHAPES, timestamp="1712345678250")
    assert parse_facecapturex_frame(data, receive_time=0).frame.capture_time == 1712345678.25


def test_all_52_names_from_the_builder() -> None:
    values = np.linspace(0.0, 1.0, 52, dtype=np.float32)
    data = build_facecapturex_frame(values, (10.0, -5.0, 3.0), camera=CAMERA, timestamp=5.5)
    parsed = parse_facecapturex_frame(data, receive_time=0.0)
    np.testing.assert_allclose(parsed.frame.blendshapes, values, atol=1e-6)
    np.testing.assert_allclose(parsed.frame.head, [10.0, -5.0, 3.0], atol=1e-3)
    assert parsed.frame.capture_time == 5.5


def test_several_pairs_in_one_field_and_bad_fields_are_skipped() -> None:
    face = cols(CAMERA @ pose(np.eye(3), (0, 0, -0.4)))
    text = f"{cols(CAMERA)}~{face}~eyeBlink_L:0.5:jawOpen:0.25~mouthClose~jawLeft:zero a"
    parsed = parse_facecapturex_frame(text.replace(" a", "a"), receive_time=0.0)
    assert parsed.frame.blendshapes[BLENDSHAPE_INDEX["eyeBlinkLeft"]] == 0.5
    assert parsed.frame.blendshapes[BLENDSHAPE_INDEX["jawOpen"]] == 0.25
    assert parsed.bad_fields == 2


def reason(data: bytes | str) -> str:
    with pytest.raises(IngestError) as info:
        parse_facecapturex_frame(data, receive_time=0.0)
    return info.value.reason


def test_rejections() -> None:
    ident = cols(np.eye(4))
    assert reason(b"") == "missing_transform"
    assert reason(f"{ident}a") == "missing_transform"
    assert reason(f"1:2:3~{ident}~jawOpen:0.1a") == "bad_transform"
    assert reason(f"{ident}~{ident.replace('1.0', 'x', 1)}~jawOpen:0.1a") == "bad_transform"
    assert reason(f"{ident}~{ident.replace('1.0', '3.0')}~jawOpen:0.1a") == "bad_transform"
    assert reason(f"{ident}~{ident.replace('1.0', 'nan', 1)}~jawOpen:0.1a") == "non_finite"
    assert reason(f"{ident}~{ident}~jawOpen:infa") == "non_finite"
    assert reason(f"1e999~{ident}~{ident}~jawOpen:0.1a") == "non_finite"
    assert reason(f"{ident}~{ident}~hatBrim:0.1a") == "no_blendshapes"
    assert reason(f"{ident}~{ident}a") == "no_blendshapes"
    assert reason(b"\xff\xfe" + ident.encode()) == "bad_encoding"
    singular = np.zeros((4, 4))
    assert reason(f"{cols(singular)}~{ident}~jawOpen:0.1a") == "bad_transform"


# --- stream splitting -------------------------------------------------------------------


def stream_frames(count: int) -> list[bytes]:
    names = [swift_raw_name(n) for n in BLENDSHAPE_NAMES]
    out = []
    for i in range(count):
        shapes = {n: round(0.01 * ((i + k) % 100), 2) for k, n in enumerate(names)}
        shapes["jawOpen"] = 1e-05 if i % 2 else 0.5  # exponent right before a terminator
        out.append(frame_text(turned_yaw(i), shapes, mesh=3 if i % 3 == 0 else 0))
    return out


def test_decoder_splits_structurally_not_on_every_a() -> None:
    frames = stream_frames(4)
    decoder = FaceCaptureXDecoder()
    got = decoder.feed(b"".join(frames))
    assert got == [f[:-1] for f in frames]
    for i, raw in enumerate(got):
        assert parse_facecapturex_frame(raw, receive_time=0).frame.head[0] == pytest.approx(
            i, abs=1e-3
        )
    assert decoder.feed(b"\r\nz") == []
    assert decoder.ended
    assert decoder.feed(frames[0]) == []


def test_value_of_nan_still_ends_its_frame() -> None:
    ident = cols(np.eye(4))
    bad = f"{ident}~{ident}~jawOpen:nana".encode()
    good = stream_frames(1)[0]
    got = FaceCaptureXDecoder().feed(bad + good)
    assert len(got) == 2
    assert reason(got[0]) == "non_finite"
    assert got[1] == good[:-1]


def test_oversized_frame_is_dropped_and_the_stream_resyncs() -> None:
    good = stream_frames(2)
    huge = frame_text(np.eye(3), SHAPES, mesh=5000)
    decoder = FaceCaptureXDecoder(max_frame_bytes=50_000)
    got = []
    stream = good[0] + huge + good[1]
    for start in range(0, len(stream), 4096):  # arrives in pieces, as from a socket
        got += decoder.feed(stream[start : start + 4096])
    assert got == [good[0][:-1], good[1][:-1]]
    assert decoder.oversized == 1
    assert decoder.pending_bytes == 0
    assert decoder.feed(huge) == []  # oversized even when it arrives in one read
    assert decoder.oversized == 2


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_arbitrary_read_boundaries(data: st.DataObject) -> None:
    frames = stream_frames(5)
    stream = b"".join(frames) + b"z"
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=40)))
    decoder = FaceCaptureXDecoder()
    got: list[bytes] = []
    for start, end in zip([0, *cuts], [*cuts, len(stream)], strict=True):
        got += decoder.feed(stream[start:end])
    assert got == [f[:-1] for f in frames]
    assert decoder.ended


@settings(max_examples=300, deadline=None)
@given(st.lists(st.binary(max_size=400), max_size=8), st.integers(1, 2000))
def test_fuzz_garbage_never_raises_anything_but_ingest_error(chunks: list[bytes], cap: int) -> None:
    decoder = FaceCaptureXDecoder(max_frame_bytes=cap)
    for chunk in [*chunks, stream_frames(1)[0]]:
        for raw in decoder.feed(chunk):
            assert len(raw) <= cap
            try:
                parsed = parse_facecapturex_frame(raw, receive_time=0.0)
            except IngestError:
                continue
            assert np.all(np.isfinite(parsed.frame.to_vector()))


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet="0123456789.:-~eEanijwOpz_LR \n", max_size=600))
def test_fuzz_protocol_alphabet(text: str) -> None:
    decoder = FaceCaptureXDecoder()
    for raw in decoder.feed(text.encode()) + decoder.feed(stream_frames(1)[0]):
        with contextlib.suppress(IngestError):
            parse_facecapturex_frame(raw, receive_time=0.0)
