"""The pose fit against poses made by projecting the canonical face with MediaPipe's own
camera (the inverse problem solved exactly), and the Procrustes solver's properties."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from chameleons.facemesh.pose import (
    PoseError,
    canonical_landmarks,
    fit_pose,
    solve_weighted_procrustes,
)
from chameleons.worker.ingest.rotation import rotation_matrix

angles = st.floats(-40, 40)


@settings(max_examples=30, deadline=None)
@given(yaw=angles, pitch=angles, roll=st.floats(-60, 60), distance=st.floats(30, 120))
def test_a_projected_canonical_face_gives_back_its_pose(
    yaw: float, pitch: float, roll: float, distance: float
) -> None:
    landmarks = canonical_landmarks(rotation=rotation_matrix(yaw, pitch, roll),
                                    distance_cm=distance)  # fmt: skip
    pose = fit_pose(landmarks, 640, 480)
    assert (pose.yaw, pose.pitch, pose.roll) == pytest.approx((yaw, pitch, roll), abs=0.05)
    assert pose.translation[2] == pytest.approx(-distance, rel=1e-3)
    assert pose.scale == pytest.approx(1.0, abs=1e-3)


def test_the_metric_landmarks_are_the_canonical_face_whatever_the_pose() -> None:
    upright = fit_pose(canonical_landmarks(), 640, 480).metric
    wide = canonical_landmarks(1280, 720, rotation=rotation_matrix(25, -10, 30))
    turned = fit_pose(wide, 1280, 720)
    assert np.abs(turned.metric - upright).max() < 1e-3


def test_irises_ride_along_with_the_mesh() -> None:
    base = canonical_landmarks()
    extra = np.vstack([base, base[:10]])  # ten more points where ten mesh points are
    pose = fit_pose(extra, 640, 480)
    assert pose.metric.shape == (478, 3)
    assert np.allclose(pose.metric[468:], pose.metric[:10], atol=1e-9)


def test_procrustes_recovers_a_similarity_and_refuses_a_reflection() -> None:
    rng = np.random.default_rng(7)
    source = rng.normal(size=(3, 50))
    turn = rotation_matrix(30, 20, -10)
    target = 2.5 * turn @ source + np.array([[1.0], [-2.0], [3.0]])
    transform = solve_weighted_procrustes(source, target, rng.uniform(0.1, 1, 50))
    assert np.allclose(transform[:3, :3], 2.5 * turn, atol=1e-9)
    assert np.allclose(transform[:3, 3], [1.0, -2.0, 3.0], atol=1e-9)
    mirrored = target * np.array([[-1.0], [1.0], [1.0]])
    fitted = solve_weighted_procrustes(source, mirrored, np.ones(50))
    assert np.linalg.det(fitted[:3, :3]) > 0


def test_bad_landmarks_are_refused_in_one_sentence() -> None:
    with pytest.raises(PoseError, match="at least 468"):
        fit_pose(np.zeros((100, 3)), 640, 480)
    with pytest.raises(PoseError, match="not finite"):
        fit_pose(np.full((468, 3), np.nan), 640, 480)
    with pytest.raises(PoseError):
        fit_pose(np.zeros((468, 3)), 640, 480)  # all points in one place
