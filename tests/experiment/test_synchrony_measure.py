"""Synchrony on synthetic interactions with known lags, noise and gaps: the copy's delay
is found, a still robot shows no peak above the surrogate band, mimicry is found and
corrected for pseudo-synchrony, gaps and the robot's speech are taken into account."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from chameleons.experiment.stats.synchrony import (
    FaceStream,
    SyncParams,
    mask_speech,
    measure_synchrony,
)
from chameleons.experiment.stats.synchrony.measure import segment_shuffles
from chameleons.experiment.stats.synchrony.streams import grid, resample, usable_share
from tests.experiment.synchrony_data import delayed, drop, smooth_face, still

# Shorter windows and fewer pseudo-pairs than the defaults keep the tests quick; the
# defaults are exercised by test_default_parameters_find_the_copy.
QUICK = SyncParams(window_s=20.0, increment_s=10.0, surrogates=12, min_between=6,
                   segment_s=20.0)  # fmt: skip
SECONDS = 100.0


def pseudo_pairs(participant: FaceStream, robot: FaceStream, count: int = 6,
                 delay: float = 4.0) -> list[tuple[FaceStream, FaceStream]]:  # fmt: skip
    """Pairs that never met: this participant with other copying robots, other
    participants with this robot."""
    pairs = []
    for seed in range(100, 100 + count):
        other = smooth_face(seed, SECONDS)
        pairs += [(participant, delayed(other, delay)), (other, robot)]
    return pairs


def test_a_copy_at_four_seconds_measures_four_seconds() -> None:
    participant = drop(smooth_face(1, SECONDS), 40.0, 41.0)  # a 1 s capture gap
    robot = delayed(participant, 4.0, noise=0.05, seed=1)
    result = measure_synchrony(participant, robot, pseudo_pairs(participant, robot), QUICK, 4.0)
    assert result.reason is None
    assert result.sync_lag_s == pytest.approx(4.0, abs=0.05)
    assert result.sync_r is not None
    assert result.sync_band_r is not None
    assert result.sync_r > 0.9 > result.sync_band_r
    assert result.check == "ok"
    assert "4.00 s" in result.check_reason
    assert result.surrogate_kind == "between"
    assert result.surrogate_count == 12
    assert result.sync_p == pytest.approx(1 / 13)  # above every pseudo-pair
    assert 0.95 < result.usable_share < 1.0  # the gap is not usable time


@pytest.mark.parametrize("delay", [3.37, 4.13])
def test_the_lag_is_found_between_grid_points(delay: float) -> None:
    participant = smooth_face(2, SECONDS)
    robot = delayed(participant, delay, noise=0.02, seed=2)
    result = measure_synchrony(participant, robot, pseudo_pairs(participant, robot), QUICK)
    assert result.sync_lag_s == pytest.approx(delay, abs=0.05)


def test_default_parameters_find_the_copy() -> None:
    participant = smooth_face(3, 120.0)
    robot = delayed(participant, 4.0, noise=0.05, seed=3)
    result = measure_synchrony(participant, robot, [], SyncParams(), 4.0)
    assert result.sync_lag_s == pytest.approx(4.0, abs=0.05)
    assert result.windows == 6  # ceil((3000 - 750 - 150 + 1) / 375)
    assert result.surrogate_kind == "segments"  # no other participants: the fallback
    assert result.check == "ok"


def test_a_copy_off_its_delay_is_flagged() -> None:
    participant = smooth_face(4, SECONDS)
    robot = delayed(participant, 4.5, noise=0.02, seed=4)
    result = measure_synchrony(participant, robot, pseudo_pairs(participant, robot), QUICK, 4.0)
    assert result.check == "failed"
    assert "4.50 s, not at the configured 4 s" in result.check_reason


def test_a_still_robot_shows_no_peak_above_the_surrogate_band() -> None:
    participant = smooth_face(5, SECONDS)
    robot = still(participant, noise=0.01, seed=5)  # holds still, sensor-like noise only
    others = [(participant, still(smooth_face(s, SECONDS), noise=0.01, seed=s))
              for s in range(200, 212)]  # fmt: skip
    result = measure_synchrony(participant, robot, others, QUICK, 4.0)
    assert result.reason is None
    assert result.sync_r is not None
    assert result.sync_band_r is not None
    assert result.sync_r <= result.sync_band_r
    assert result.sync_p is not None
    assert result.sync_p > 0.05
    assert result.check == "failed"  # had it been a copy: the manipulation did not run
    assert "not above the surrogate band" in result.check_reason or "not at" in result.check_reason


def test_a_robot_that_does_not_move_at_all_gives_a_reason() -> None:
    participant = smooth_face(6, SECONDS)
    result = measure_synchrony(participant, still(participant), [], QUICK)
    assert result.reason == "robot_still"
    assert result.sync_r is None
    assert "did not move" in result.detail


def test_a_still_robot_that_ends_its_switch_in_the_recording_is_still() -> None:
    """Seen in a rehearsal: the still interaction's recording began with the last two
    frames of the robot's 0.3 s crossfade from the natural condition before (a head 0.002
    rad off neutral). That was "moving", and it gave a mimicry lag and no sync lag with no
    reason. The first second (``settle_s``) is left out, so the robot is still."""
    participant = smooth_face(16, SECONDS)
    robot = still(participant)
    values = robot.values.copy()
    values[:2, robot.channels.index("head_yaw")] = [-0.0023, -0.0011]  # the fade's end
    switching = FaceStream(robot.times, values, robot.channels)
    result = measure_synchrony(participant, switching, [], QUICK)
    assert result.reason == "robot_still"
    assert result.sync_lag_s is None
    assert result.mimicry_lag_s is None
    unsettled = measure_synchrony(participant, switching, [], replace(QUICK, settle_s=0.0))
    assert unsettled.reason is None  # without it: "moving", as in the rehearsal
    assert unsettled.channels == ["head_yaw"]


def test_mimicry_of_the_robot_is_found_and_surrogate_corrected() -> None:
    robot = smooth_face(7, SECONDS + 5)  # a natural robot: its own movement
    participant = delayed(robot, 1.5, noise=0.3, seed=7)  # the participant follows at 1.5 s
    others = [(smooth_face(s, SECONDS), robot) for s in range(300, 306)]
    others += [(participant, smooth_face(s, SECONDS)) for s in range(310, 316)]
    result = measure_synchrony(participant, robot, others, QUICK)
    assert result.mimicry_lag_s == pytest.approx(1.5, abs=0.05)
    assert result.mimicry_raw_r is not None
    assert result.mimicry_r is not None
    assert result.mimicry_surrogate_r is not None
    assert 0 < result.mimicry_r < result.mimicry_raw_r  # the pseudo-synchrony is removed
    assert result.mimicry_p == pytest.approx(1 / 13)
    assert result.check is None  # not a copy interaction: nothing to check


def test_no_mimicry_is_about_zero_after_correction() -> None:
    robot = smooth_face(8, SECONDS + 5)
    participant = smooth_face(9, SECONDS)  # moves on their own
    others = [(smooth_face(s, SECONDS), robot) for s in range(400, 406)]
    others += [(participant, smooth_face(s, SECONDS)) for s in range(410, 416)]
    result = measure_synchrony(participant, robot, others, QUICK)
    assert result.mimicry_r is not None
    assert abs(result.mimicry_r) < 0.1
    assert result.mimicry_p is not None
    assert result.mimicry_p > 0.05


def test_capture_gaps_are_missing_and_reduce_the_usable_share() -> None:
    participant = drop(smooth_face(10, SECONDS), 30.0, 50.0)
    robot = delayed(smooth_face(10, SECONDS), 4.0)
    times = grid(0.0, SECONDS, 25)
    values = resample(participant, times, 0.25)
    assert np.isnan(values[(times > 30.1) & (times < 49.9)]).all()
    assert np.isfinite(values[(times > 1.0) & (times < 29.0)]).all()
    share = usable_share(participant, robot, 25, 0.25)
    assert share == pytest.approx((SECONDS - 20.0) / (SECONDS + 4.0), abs=0.01)


def test_the_robots_mouth_is_not_compared_while_it_speaks() -> None:
    participant = smooth_face(11, SECONDS)
    robot = delayed(participant, 4.0)
    speech = [(10.0, 20.0), (50.0, 55.0)]
    masked = mask_speech(robot, speech, QUICK)
    jaw, brow = robot.channels.index("jawOpen"), robot.channels.index("browInnerUp")
    during = (robot.times >= 9.5) & (robot.times <= 20.5)
    assert np.isnan(masked.values[during, jaw]).all()
    assert np.isnan(masked.values[during, robot.channels.index("mouthSmileLeft")]).all()
    assert np.isfinite(masked.values[during, brow]).all()  # the brows are not lip-sync
    assert np.isfinite(masked.values[~during & (robot.times < 49), jaw]).all()


def test_lip_sync_does_not_make_a_still_robot_look_synchronous() -> None:
    participant = smooth_face(12, SECONDS)
    robot = still(participant)
    rng = np.random.default_rng(12)
    speaking = (robot.times > 10) & (robot.times < 80)
    values = robot.values.copy()
    values[speaking, robot.channels.index("jawOpen")] = rng.uniform(0, 1, speaking.sum())
    talking = FaceStream(robot.times, values, robot.channels)
    result = measure_synchrony(participant, mask_speech(talking, [(10.0, 80.0)], QUICK), [], QUICK)
    assert result.reason == "robot_still"


def test_too_short_a_recording_says_how_long_it_needs() -> None:
    participant = smooth_face(13, 20.0)
    result = measure_synchrony(participant, delayed(participant, 4.0), [], QUICK)
    assert result.reason == "too_short"
    assert "at least 27 s" in result.detail  # the first second, the window, the lag


def test_segment_shuffles_never_keep_two_segments_of_the_same_time() -> None:
    p = np.arange(500.0)[:, None]
    r = np.arange(500.0)[:, None] + 0.5
    pairs = segment_shuffles(p, r, SyncParams(rate_hz=25, segment_s=4.0), 20)
    assert len(pairs) == 20
    for a, b in pairs:
        assert a.shape == b.shape == (500, 1)  # 5 segments of 100 samples
        starts_a = a[::100, 0] // 100
        starts_b = b[::100, 0] // 100
        assert sorted(starts_a) == list(range(5))
        assert np.all(starts_a != starts_b)


def test_the_result_records_how_it_was_computed() -> None:
    participant = smooth_face(14, SECONDS)
    result = measure_synchrony(participant, delayed(participant, 4.0), [], QUICK)
    assert result.params["window_s"] == 20.0
    assert result.params["method_version"] == 2
    assert result.lags_s[0] == -6.0
    assert result.lags_s[-1] == 6.0
    assert len(result.curve) == len(result.lags_s) == len(result.surrogate_high)
    assert set(result.channels) == set(participant.channels)


def test_a_short_interaction_still_gets_a_within_interaction_baseline() -> None:
    participant = smooth_face(15, 50.0)  # 50 s: not two 30 s segments, four of 12.5 s
    robot = delayed(participant, 4.0, noise=0.02, seed=15)
    result = measure_synchrony(participant, robot, [], SyncParams(), 4.0)
    assert result.surrogate_kind == "segments"
    assert result.surrogate_count == 40
    assert result.segment_s == pytest.approx(12.24)  # 1224 samples // 4 at 25 Hz (after settle_s)
    assert result.detail == ""
    assert result.mimicry_r is not None
    assert result.sync_band_r is not None
    assert result.check == "ok"


def test_too_short_for_any_baseline_says_so() -> None:
    participant = smooth_face(16, 40.0)  # windows fit (20 s + 12 s lag), four 12 s segments not
    robot = delayed(participant, 4.0, noise=0.02, seed=16)
    params = SyncParams(window_s=20.0, increment_s=10.0, max_lag_s=12.0, segment_s=20.0)
    result = measure_synchrony(participant, robot, [], params, 4.0)
    assert result.reason is None  # the copy was measured
    assert result.sync_lag_s == pytest.approx(4.0, abs=0.05)
    assert result.surrogate_kind == "none"
    assert result.mimicry_r is None
    assert result.sync_band_r is None
    assert result.detail.startswith("No surrogate baseline")
    assert "(no surrogate band to compare with)" in result.check_reason
