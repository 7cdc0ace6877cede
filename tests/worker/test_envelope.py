"""The message envelope and the face-frame type: exact round trips, bad frames refused."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from chameleons.worker.envelope import (
    EnvelopeError,
    Message,
    deserialize,
    frame_message,
    message_frame,
    serialize,
)
from chameleons.worker.frames import (
    BLENDSHAPE_NAMES,
    MIRROR_PERMUTATION,
    FaceFrame,
    canonical_name,
    swift_raw_name,
    upper_snake,
)

text = st.text(alphabet=st.characters(exclude_categories=["Cs"]), max_size=20)
finite = st.floats(allow_nan=False, allow_infinity=False)
json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | finite | text,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(text, inner, max_size=4),
    max_leaves=12,
)
messages = st.builds(
    Message,
    topic=text,
    type=text,
    seq=st.integers(),
    source=text,
    time=finite,
    body=st.dictionaries(text, json_values, max_size=5),
    payload=st.binary(max_size=64).map(lambda b: b[: len(b) - len(b) % 4]),
)


@settings(max_examples=150, deadline=None)
@given(messages)
def test_serialize_and_deserialize_are_exact_inverses(message: Message) -> None:
    frames = serialize(message)
    assert len(frames) == 3
    assert all(isinstance(f, bytes) for f in frames)
    assert deserialize(frames) == message
    assert serialize(deserialize(frames)) == frames


@settings(max_examples=300, deadline=None)
@given(st.lists(st.binary(max_size=80), max_size=4))
def test_arbitrary_frames_give_a_message_or_envelope_error(frames: list[bytes]) -> None:
    try:
        message = deserialize(frames)
    except EnvelopeError as exc:
        reason = exc.reason
        assert reason in {"frame_count", "bad_header", "bad_payload"}
        return
    assert serialize(message)[2] == frames[2]


def header(**overrides: Any) -> bytes:
    fields = {"type": "face", "seq": 1, "source": "ingest", "time": 1.5, "body": {}}
    fields.update(overrides)
    return json.dumps({k: v for k, v in fields.items() if v is not ...}).encode()


@pytest.mark.parametrize(
    ("frames", "reason"),
    [
        ([b"t", header()], "frame_count"),
        ([b"t", header(), b"", b""], "frame_count"),
        ([b"t", b"{not json", b""], "bad_header"),
        ([b"t", b"[1, 2]", b""], "bad_header"),
        ([b"\xff", header(), b""], "bad_header"),
        ([b"t", header(seq=...), b""], "bad_header"),
        ([b"t", header(extra=1), b""], "bad_header"),
        ([b"t", header(seq=True), b""], "bad_header"),
        ([b"t", header(seq="1"), b""], "bad_header"),
        ([b"t", header(time="now"), b""], "bad_header"),
        ([b"t", header(time=False), b""], "bad_header"),
        ([b"t", header(body=[]), b""], "bad_header"),
        ([b"t", header(type=3), b""], "bad_header"),
        ([b"t", b'{"type":"f","seq":1,"source":"","time":NaN,"body":{}}', b""], "bad_header"),
        ([b"t", b"[" * 100_000, b""], "bad_header"),
        ([b"t", header(), b"abc"], "bad_payload"),
    ],
)
def test_bad_frames_are_refused_with_a_reason(frames: list[bytes], reason: str) -> None:
    with pytest.raises(EnvelopeError) as info:
        deserialize(frames)
    assert info.value.reason == reason


def test_non_finite_time_is_refused_when_sending() -> None:
    with pytest.raises(ValueError, match="JSON"):
        serialize(Message("t", "face", time=math.inf))


vectors = arrays(
    np.float32, 61, elements=st.floats(width=32, allow_nan=False, allow_infinity=False)
)


@settings(max_examples=100, deadline=None)
@given(vectors, finite, finite, text)
def test_face_frames_travel_exactly(vector: np.ndarray, capture: float, receive: float,
                                    source: str) -> None:  # fmt: skip
    frame = FaceFrame.from_vector(vector, capture, receive, source)
    message = frame_message(frame, "face.participant", seq=7, source="ingest", time=2.0)
    back = message_frame(deserialize(serialize(message)))
    np.testing.assert_array_equal(back.to_vector(), vector)
    assert (back.capture_time, back.receive_time, back.source) == (capture, receive, source)
    assert message.body["capture_time"] == capture
    assert len(message.payload) == 61 * 4  # raw float32, not JSON


def test_malformed_face_messages() -> None:
    good = frame_message(FaceFrame(1.0, 2.0), "face.participant", seq=1, source="s", time=0.0)
    with pytest.raises(EnvelopeError, match="bad_face"):
        message_frame(Message("f", "face", body=good.body, payload=good.payload[:-4]))
    with pytest.raises(EnvelopeError, match="bad_face"):
        message_frame(Message("f", "face", body={}, payload=good.payload))
    with pytest.raises(EnvelopeError, match="bad_face"):
        message_frame(
            Message("f", "face", body=good.body, payload=np.full(61, np.nan, "<f4").tobytes())
        )


# --- frames.py ---------------------------------------------------------------------------


def test_every_spelling_maps_to_the_canonical_name() -> None:
    assert len(BLENDSHAPE_NAMES) == 52
    for name in BLENDSHAPE_NAMES:
        pascal = name[0].upper() + name[1:]
        for spelling in (name, pascal, swift_raw_name(name), upper_snake(name), f" {name} "):
            assert canonical_name(spelling) == name, spelling
    assert swift_raw_name("eyeBlinkLeft") == "eyeBlink_L"
    assert swift_raw_name("mouthSmileRight") == "mouthSmile_R"
    assert swift_raw_name("jawLeft") == "jawLeft"
    assert swift_raw_name("mouthRight") == "mouthRight"
    assert swift_raw_name("cheekPuff") == "cheekPuff"
    assert upper_snake("eyeBlinkLeft") == "EYE_BLINK_LEFT"
    for unknown in ("HeadYaw", "_neutral", "", "eyeBlink", "blink_L"):
        assert canonical_name(unknown) is None


def test_mirroring() -> None:
    assert sorted(MIRROR_PERMUTATION) == list(range(52))
    np.testing.assert_array_equal(MIRROR_PERMUTATION[MIRROR_PERMUTATION], np.arange(52))
    frame = FaceFrame.from_vector((np.arange(61) / 100).astype(np.float32), 1.0, 2.0, "x")
    mirrored = frame.mirrored()
    left, right = (
        BLENDSHAPE_NAMES.index("mouthSmileLeft"),
        BLENDSHAPE_NAMES.index("mouthSmileRight"),
    )
    assert mirrored.blendshapes[left] == frame.blendshapes[right]
    jaw_left, jaw_right = BLENDSHAPE_NAMES.index("jawLeft"), BLENDSHAPE_NAMES.index("jawRight")
    assert mirrored.blendshapes[jaw_left] == frame.blendshapes[jaw_right]
    np.testing.assert_allclose(mirrored.head, frame.head * [-1, 1, -1])
    np.testing.assert_allclose(mirrored.eyes[:3], frame.eyes[3:] * [-1, 1, -1])
    np.testing.assert_array_equal(mirrored.mirrored().to_vector(), frame.to_vector())


def test_from_vector_checks_the_shape() -> None:
    with pytest.raises(ValueError, match="61"):
        FaceFrame.from_vector(np.zeros(60, dtype=np.float32), 0.0, 0.0)
