"""The windowed lagged cross-correlation against a second, independent implementation: a
loop-by-loop transcription of rMEA's MEAccf (tests/experiment/meaccf_reference.py)."""

from __future__ import annotations

import numpy as np
import pytest

from chameleons.experiment.stats.synchrony import SyncParams
from chameleons.experiment.stats.synchrony.ccf import layout, windowed_ccf
from chameleons.experiment.stats.synchrony.streams import grid, resample
from tests.experiment.meaccf_reference import fisher_r2z, meaccf, r_cor_complete
from tests.experiment.synchrony_data import delayed, drop, smooth_face

RATE = 25


def recorded_like(seed: int, seconds: float) -> tuple[np.ndarray, np.ndarray]:
    """Two faces as the service prepares them: a participant captured at 60 Hz with a
    capture gap, a robot copying at 4 s with noise, both resampled to 25 Hz (so the copy
    is never identical to the last bit, as in a real recording)."""
    participant = drop(smooth_face(seed, seconds), 20.0, 23.5)
    robot = delayed(participant, 4.0, noise=0.02, seed=seed)
    times = grid(max(participant.start, robot.start), min(participant.end, robot.end), RATE)
    return resample(participant, times, 0.25).T, resample(robot, times, 0.25).T


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_matches_the_loop_transcription_of_meaccf(seed: int) -> None:
    p, r = recorded_like(seed, 75.0)
    win, inc, lag = 20 * RATE, 10 * RATE, 6 * RATE
    fast = windowed_ccf(p, r, win, inc, lag)
    assert fast.shape[1] == layout(p.shape[1], win, inc, lag).n_windows >= 3
    for channel in (0, 3, 7):  # head yaw, a brow, the jaw
        slow = meaccf(p[channel], r[channel], RATE, 6, 20, 10)
        assert slow.shape == fast[channel].shape
        assert np.array_equal(np.isnan(slow), np.isnan(fast[channel]))
        assert np.isnan(slow).sum() < slow.size  # the comparison is not of NaNs only
        np.testing.assert_allclose(fast[channel], slow, rtol=0, atol=1e-9)


def test_window_count_and_missing_windows_follow_meaccf() -> None:
    rng = np.random.default_rng(5)
    x, y = rng.standard_normal(400), rng.standard_normal(400)
    x[60:130] = np.nan  # more than half of the first window (100 + 20 samples) missing
    fast = windowed_ccf(x, y, 100, 50, 20)[0]
    slow = meaccf(x, y, 10, 2, 10, 5)
    assert fast.shape == slow.shape == (6, 41)  # ceil((400 - 100 - 20 + 1) / 50)
    assert np.isnan(fast[1]).all()
    assert np.isnan(slow[1]).all()
    np.testing.assert_allclose(fast, slow, atol=1e-12)


def test_positive_lags_mean_the_second_series_follows() -> None:
    rng = np.random.default_rng(7)
    x = np.convolve(rng.standard_normal(600), np.ones(5) / 5, mode="same")
    y = np.roll(x, 12) + 0.01 * rng.standard_normal(600)  # y is x, 12 samples later
    curve = np.nanmean(windowed_ccf(x, y, 200, 100, 30)[0], axis=0)
    assert int(np.nanargmax(curve)) - 30 == 12


def test_reference_helpers_agree_with_numpy() -> None:
    rng = np.random.default_rng(9)
    a, b = rng.standard_normal(50), rng.standard_normal(50)
    assert r_cor_complete(list(a), list(b)) == pytest.approx(np.corrcoef(a, b)[0, 1], abs=1e-12)
    assert fisher_r2z(1.0) == 10.0
    assert fisher_r2z(0.5) == pytest.approx(np.arctanh(0.5))


def test_constant_windows_are_missing_not_correlated() -> None:
    x = np.sin(np.arange(300) / 7.0)
    y = np.full(300, 0.25)  # a still robot
    assert np.isnan(windowed_ccf(x, y, 100, 50, 20)).all()


def test_parameters_must_be_whole_samples() -> None:
    with pytest.raises(ValueError, match="whole number of samples"):
        SyncParams(rate_hz=25, window_s=30.01)
    with pytest.raises(ValueError, match="do not fit"):
        windowed_ccf(np.zeros(10), np.zeros(10), 2, 1, 1)
