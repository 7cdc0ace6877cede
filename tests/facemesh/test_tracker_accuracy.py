"""The Python tracker on real faces (tests/support/faces.py: two public-domain portraits)
turned into frame sequences with known in-plane rotation, scale, translation, occlusion and
stretches without a face. Truth we did not make up: the roll the test itself applied to
the photo, the same face's yaw and pitch wherever it is put, and an empty frame."""

from __future__ import annotations

import numpy as np
import pytest

from chameleons.facemesh.tracker import FaceTracker
from tests.support.faces import Motion, Video, scene

PHOTOS = ("astronaut", "grace_hopper")
ROLL_TOLERANCE = 3.0  # degrees, against the rotation applied
STEADY_TOLERANCE = 6.0  # degrees of yaw/pitch change while the face only moves in the image


@pytest.fixture(scope="module")
def tracker() -> FaceTracker:
    return FaceTracker()


@pytest.mark.slow
@pytest.mark.parametrize("name", PHOTOS)
def test_known_roll_and_steady_yaw_pitch_through_a_sequence(
    tracker: FaceTracker, name: str
) -> None:
    video = Video(tracker, name)
    base = video.go(Motion())
    assert base is not None
    for angle in (-35, -20, -10, 10, 20, 35):
        head = video.go(Motion(angle=angle))
        assert head is not None, angle
        assert head[2] - base[2] == pytest.approx(angle, abs=ROLL_TOLERANCE), angle
        assert np.abs(head[:2] - base[:2]).max() < STEADY_TOLERANCE, (angle, head, base)
    moves = [Motion(scale=s) for s in (0.7, 1.3, 1.6)] + [
        Motion(dx=dx, dy=dy) for dx, dy in ((-150, 0), (150, 0), (0, -90), (0, 90))
    ] + [Motion(angle=20, scale=1.3, dx=60, dy=-40)]
    for motion in moves:
        head = video.go(motion)
        assert head is not None, motion
        assert head[2] - base[2] == pytest.approx(motion.angle, abs=ROLL_TOLERANCE), motion
        assert np.abs(head[:2] - base[:2]).max() < STEADY_TOLERANCE, (motion, head, base)
        video.go(Motion())  # back to the middle, as a head in a booth does


@pytest.mark.parametrize("name", PHOTOS)
@pytest.mark.parametrize("part", ["mouth", "eye"])
def test_a_partly_covered_face_is_still_tracked(tracker: FaceTracker, name: str,
                                                part: str) -> None:  # fmt: skip
    video = Video(tracker, name)
    base = video.go(Motion())
    assert base is not None
    head = video.go(Motion(angle=15, occlude=part))
    assert head is not None
    assert head[2] - base[2] == pytest.approx(15, abs=ROLL_TOLERANCE + 1)
    assert np.abs(head[:2] - base[:2]).max() < STEADY_TOLERANCE + 3


def test_no_face_on_empty_frames_and_the_face_found_again(tracker: FaceTracker) -> None:
    assert Video(tracker, "astronaut").go(Motion()) is not None
    for _ in range(4):
        assert tracker.process(scene("astronaut", Motion(face=False))) is None
    noise = np.random.default_rng(3).integers(0, 256, (480, 640, 3), dtype=np.uint8)
    assert tracker.process(noise) is None
    assert tracker.process(np.zeros((480, 640, 3), np.uint8)) is None
    back = tracker.process(scene("astronaut", Motion(angle=10)))
    assert back is not None
    assert back.detected  # a new detection started the track


def test_the_tracker_refuses_what_is_not_an_rgb_image(tracker: FaceTracker) -> None:
    with pytest.raises(ValueError, match="uint8 RGB"):
        tracker.process(np.zeros((480, 640), np.uint8))
