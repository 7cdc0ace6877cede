"""Mounting rotation, mirroring, the rotation convention, clock alignment and counters."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from chameleons.settings import Settings
from chameleons.worker.frames import BLENDSHAPE_INDEX, FaceFrame
from chameleons.worker.ingest.rotation import rotation_matrix, yaw_pitch_roll
from chameleons.worker.ingest.stats import CaptureStats, ClockAligner
from chameleons.worker.ingest.transform import FrameTransform, apply_mounting_rotation


def face(yaw: float = 0.0, pitch: float = 0.0, roll: float = 0.0) -> FaceFrame:
    frame = FaceFrame(1.0, 2.0, source="test")
    frame.head[:] = (yaw, pitch, roll)
    frame.blendshapes[BLENDSHAPE_INDEX["eyeBlinkLeft"]] = 0.75
    frame.eyes[:] = (1, 2, 3, 4, 5, 6)
    return frame


@settings(max_examples=200, deadline=None)
@given(st.floats(-179, 179), st.floats(-89, 89), st.floats(-179, 179))
def test_rotation_round_trip(yaw: float, pitch: float, roll: float) -> None:
    back = yaw_pitch_roll(rotation_matrix(yaw, pitch, roll))
    np.testing.assert_allclose(back, (yaw, pitch, roll), atol=1e-6)


def test_phone_mounted_sideways_reads_roll_and_the_setting_undoes_it() -> None:
    # a phone turned 90 deg clockwise sees an upright head rolled by -90 and its yaw as pitch
    seen = yaw_pitch_roll(rotation_matrix(0, 0, -90) @ rotation_matrix(25, 0, 0))
    corrected = apply_mounting_rotation(face(*seen), 90.0)
    np.testing.assert_allclose(corrected.head, (25, 0, 0), atol=1e-4)
    np.testing.assert_array_equal(corrected.eyes, face().eyes)  # eyes are head-relative


def test_zero_mounting_is_the_identity() -> None:
    frame = face(10, 20, 30)
    assert apply_mounting_rotation(frame, 0.0) is frame
    assert apply_mounting_rotation(frame, 360.0) is frame


def test_mirror_setting() -> None:
    mirrored = FrameTransform(mirror=True).apply(face(10, 5, -3))
    np.testing.assert_allclose(mirrored.head, (-10, 5, 3))
    assert mirrored.blendshapes[BLENDSHAPE_INDEX["eyeBlinkRight"]] == 0.75
    same = FrameTransform(mirror=False).apply(face(10, 5, -3))
    np.testing.assert_allclose(same.head, (10, 5, -3))


def test_transform_from_settings() -> None:
    transform = FrameTransform.from_settings(Settings(mounting_rotation_deg=90, mirror=False))
    assert transform == FrameTransform(90.0, False)
    assert Settings().mirror is True  # the study mirrors the participant back
    assert Settings().livelink_rotation_scale == "radians"  # the app's unit
    with pytest.raises(ValueError, match="livelink_rotation_scale"):
        Settings(livelink_rotation_scale="furlongs")


def test_clock_aligner_removes_jitter_and_follows_jumps() -> None:
    aligner = ClockAligner()
    sender = np.arange(100) / 60.0
    jitter = np.random.default_rng(1).uniform(0.0, 0.02, 100)
    jitter[0] = 0.015
    receive = 500.0 + sender + jitter
    local = np.array([aligner.align(s, r) for s, r in zip(sender, receive, strict=True)])
    assert np.all(local <= receive + 1e-12)
    later = local[np.argmin(jitter) :]  # after the least-delayed frame: exact spacing
    np.testing.assert_allclose(np.diff(later), 1 / 60, atol=4e-5)  # drift allowance: 1 ms/s
    # the sender restarts its clock: capture times follow at once
    assert aligner.align(0.0, 510.0) == pytest.approx(510.0)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(1e-4, 0.05), st.floats(0.0, 0.2)), min_size=2, max_size=60))
def test_capture_times_increase_and_never_pass_the_receive_time(
    steps: list[tuple[float, float]],
) -> None:
    """Each step: sender time advances by a, the frame waits d (stalls, bursts, jitter)."""
    aligner = ClockAligner()
    sender, last_receive, previous = 0.0, 50.0, -math.inf
    for advance, delay in steps:
        sender += advance
        receive = max(last_receive + 1e-6, 50.0 + sender + delay)  # arrivals are in order
        local = aligner.align(sender, receive)
        assert previous < local <= receive
        previous, last_receive = local, receive


def test_clock_aligner_tracks_slow_drift() -> None:
    aligner = ClockAligner(max_drift=1e-3)
    for i in range(6000):  # 100 s at 60 Hz, sender clock 500 ppm slow
        t = i / 60.0
        local = aligner.align(t * (1 - 5e-4), 10.0 + t)
    assert local == pytest.approx(10.0 + 100 - 1 / 60, abs=2e-3)


def test_stats_counters_and_rate() -> None:
    now = [100.0]
    stats = CaptureStats(clock=lambda: now[0])
    for i in range(61):
        stats.count_frame(99.0 + i / 60)
    stats.count_drop("truncated")
    stats.count_drop("truncated", 2)
    stats.count_unknown(3, 1)
    stats.set_connected(True)
    snap = stats.snapshot()
    assert snap["input_fps"] == pytest.approx(60.0)
    assert snap["drops"] == {"truncated": 3}
    assert snap["dropped"] == 3
    assert (snap["frames"], snap["unknown_names"], snap["bad_fields"]) == (61, 3, 1)
    assert (snap["connected"], snap["connections"]) == (True, 1)
    now[0] = 110.0  # the input stopped
    assert stats.input_fps == 0.0
