"""The ARKit mapping: missing channels, the neutral face, and expressions that do not move
when only the head moves in the image (real photos, tests/support/faces.py)."""

from __future__ import annotations

import numpy as np
import pytest

from chameleons.facemesh.arkit import NEVER_DERIVED, expression, neutral_from
from chameleons.facemesh.features import FEATURE_INDEX, N_FEATURES, measure
from chameleons.facemesh.mapping import Calibration, read_face
from chameleons.facemesh.pose import canonical_landmarks, fit_pose
from chameleons.facemesh.tracker import FaceTracker
from chameleons.worker.frames import BLENDSHAPE_INDEX
from tests.support.faces import Motion, Video, scene


@pytest.fixture(scope="module")
def tracker() -> FaceTracker:
    return FaceTracker(static_images=True)


def test_underivable_channels_are_missing_not_zero() -> None:
    mesh = fit_pose(canonical_landmarks(), 640, 480).metric
    without_irises = expression(measure(mesh))
    names = {*NEVER_DERIVED, "eyeLookInLeft", "eyeLookUpRight"}
    for name in names:
        assert np.isnan(without_irises.blendshapes[BLENDSHAPE_INDEX[name]]), name
        assert BLENDSHAPE_INDEX[name] in without_irises.missing
    irises = np.vstack([mesh, mesh[[33] * 5], mesh[[263] * 5]])  # irises at the eye corners
    with_irises = expression(measure(irises))
    assert set(with_irises.missing) == {BLENDSHAPE_INDEX[n] for n in NEVER_DERIVED}
    # Both irises at the outer corners: both eyes look outwards, not inwards.
    for side in ("Left", "Right"):
        assert with_irises.blendshapes[BLENDSHAPE_INDEX[f"eyeLookOut{side}"]] == 1.0
        assert with_irises.blendshapes[BLENDSHAPE_INDEX[f"eyeLookIn{side}"]] == 0.0
    assert with_irises.eyes[0] > 20  # left eye turned towards +x (its outward side)
    assert with_irises.eyes[3] < -20


def test_a_face_calibrated_on_itself_reads_neutral(tracker: FaceTracker) -> None:
    face = tracker.process(scene("astronaut", Motion()))
    assert face is not None
    smiling = read_face(face.landmarks, 640, 480)
    assert smiling.blendshapes[BLENDSHAPE_INDEX["mouthSmileLeft"]] > 0.4
    assert smiling.blendshapes[BLENDSHAPE_INDEX["mouthSmileRight"]] > 0.4
    own = Calibration(neutral=neutral_from([smiling.features] * 3))
    rest = read_face(face.landmarks, 640, 480, own)
    assert np.nanmax(rest.blendshapes) < 0.05
    assert own.label() == "neutral"
    assert Calibration().label() == "geometric"


# Measured spread of the geometric defaults on these photos at webcam scale (docs/science.md):
# up to 0.34 on one channel when the head rolls 25-30 degrees; the smile within 0.1.
STEADY_CHANNELS, STEADY_SMILE = 0.4, 0.15


@pytest.mark.parametrize("motion", [Motion(angle=25), Motion(angle=-30, scale=1.3),
                                    Motion(scale=0.75)])  # fmt: skip
def test_expressions_stay_when_the_head_only_moves_in_the_image(motion: Motion) -> None:
    tracker = FaceTracker()
    video = Video(tracker, "astronaut")
    values = []
    for m in (Motion(), motion):
        video.go(m)
        frames = [tracker.process(scene("astronaut", m)) for _ in range(5)]
        values.append(np.mean([read_face(f.landmarks, 640, 480).blendshapes
                               for f in frames if f is not None], axis=0))  # fmt: skip
    derived = np.isfinite(values[0])
    assert np.abs(values[1][derived] - values[0][derived]).max() < STEADY_CHANNELS
    for side in ("Left", "Right"):
        smile = BLENDSHAPE_INDEX[f"mouthSmile{side}"]
        assert values[0][smile] > 0.4  # she smiles
        assert values[1][smile] == pytest.approx(values[0][smile], abs=STEADY_SMILE)


def test_the_neutral_face_is_each_feature_s_median_and_gaze_rests_at_zero() -> None:
    rows = np.random.default_rng(1).normal(size=(9, N_FEATURES))
    neutral = neutral_from(rows)
    assert neutral[FEATURE_INDEX["jaw_drop"]] == pytest.approx(
        float(np.median(rows[:, FEATURE_INDEX["jaw_drop"]])))
    assert neutral[FEATURE_INDEX["gaze_x_L"]] == 0.0
    with pytest.raises(ValueError, match="no frames"):
        neutral_from(np.zeros((0, N_FEATURES)))
