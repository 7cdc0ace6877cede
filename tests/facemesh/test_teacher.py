"""The iPhone as teacher: the ridge fit, its held-out agreement and lag, the stored map.

Paired data: webcam features measured by the real tracker on a real photo
(tests/support/faces.py) in a sequence of in-plane rolls (real landmark noise), and
"iPhone" values made from those features by a known linear rule, delayed by a known lag
and noised: the fit must find the rule (R² near 1 on held-out frames), the lag, and nothing
where there is nothing to find."""

from __future__ import annotations

import numpy as np
import pytest

from chameleons.facemesh.arkit import NEVER_DERIVED, default_neutral
from chameleons.facemesh.features import FEATURE_INDEX, N_FEATURES
from chameleons.facemesh.mapping import Calibration, read_face
from chameleons.facemesh.teacher import fit_map, map_from_json, map_to_json
from chameleons.facemesh.tracker import FaceTracker
from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES
from tests.support.faces import Motion, scene

RATE = 30.0


def paired(n: int = 240, lag: int = 3) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(5)
    tracker = FaceTracker()
    rows = []
    for k in range(n):
        face = tracker.process(scene("astronaut", Motion(angle=20 * np.sin(k / 9))))
        assert face is not None
        rows.append(read_face(face.landmarks, 640, 480).features)
    features = np.array(rows)
    # The features move little on a still photo: add a known expression signal on two.
    signal = 0.5 + 0.5 * np.sin(np.arange(n) / 7)
    features[:, FEATURE_INDEX["jaw_drop"]] += 0.3 * signal
    features[:, FEATURE_INDEX["corner_y_L"]] += 0.1 * np.cos(np.arange(n) / 5)
    delta = np.nan_to_num(features - default_neutral())
    targets = np.zeros((n, N_BLENDSHAPES))
    jaw = np.clip(2.0 * delta[:, FEATURE_INDEX["jaw_drop"]] + 0.1, 0, 1)
    smile = np.clip(3.0 * delta[:, FEATURE_INDEX["corner_y_L"]] + 0.5, 0, 1)
    targets[:, BLENDSHAPE_INDEX["jawOpen"]] = np.roll(jaw, -lag)  # the iPhone leads by lag
    targets[:, BLENDSHAPE_INDEX["mouthSmileLeft"]] = np.roll(smile, -lag)
    targets[:, BLENDSHAPE_INDEX["browInnerUp"]] = rng.uniform(0, 1, n)  # nothing to learn
    targets += rng.normal(0, 0.01, targets.shape)
    return features, np.clip(targets, 0, 1)


@pytest.mark.slow
def test_the_fit_finds_the_rule_the_lag_and_nothing_in_noise() -> None:
    features, targets = paired()
    teaching = fit_map(features, targets, default_neutral(), rate=RATE)
    reports = {r.channel: r for r in teaching.channels}
    for channel in ("jawOpen", "mouthSmileLeft"):
        assert reports[channel].r2 > 0.8, reports[channel]
        assert reports[channel].correlation > 0.9
        assert reports[channel].lag_s == pytest.approx(3 / RATE, abs=1.5 / RATE)
    assert reports["browInnerUp"].r2 < 0.2
    assert not set(NEVER_DERIVED) & set(reports)
    assert teaching.aligned_s == pytest.approx(3 / RATE, abs=1.5 / RATE)
    assert teaching.test_frames == pytest.approx(60, abs=1)
    stored = map_from_json(map_to_json(teaching.mapping, teaching))
    assert stored.name == teaching.mapping.name
    assert stored.name.startswith("iphone:")
    assert Calibration(None, stored).label() == stored.name
    tampered = map_to_json(teaching.mapping).replace('"bias": [', '"bias": [0.5, ', 1)
    with pytest.raises(ValueError, match=r"hash"):
        map_from_json(tampered)


def test_too_few_frames_are_refused() -> None:
    with pytest.raises(ValueError, match="too few"):
        fit_map(np.zeros((12, N_FEATURES)), np.zeros((12, N_BLENDSHAPES)), default_neutral(),
                rate=RATE)  # fmt: skip
