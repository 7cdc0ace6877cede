"""The booth check's copy-delay probe: a head turn and its copy sent ``delay`` seconds
later (at the robot's 25 Hz against the phone's 60 Hz) give that delay back; a still head
or a copy of something else gives no figure."""

from __future__ import annotations

import numpy as np
import pytest

from chameleons.worker.delay_probe import DelayProbe


def turn(t: np.ndarray) -> np.ndarray:
    """A turn to the left and back, then a smaller one to the right (degrees)."""
    yaw: np.ndarray = 30 * np.exp(-(((t - 3) / 0.6) ** 2)) - 10 * np.exp(-(((t - 6) / 0.5) ** 2))
    return yaw


def fed(delay: float, copy: np.ndarray | None = None) -> DelayProbe:
    probe = DelayProbe()
    captured = np.arange(0.0, 18.0, 1 / 60)
    for t, yaw in zip(captured, turn(captured), strict=True):
        probe.captured(float(t), float(yaw))
    sent = np.arange(0.0, 18.0, 1 / 25)
    yaws = turn(sent - delay) if copy is None else copy[: len(sent)]
    for t, yaw in zip(sent, yaws, strict=True):
        probe.sent(float(t), float(yaw))
    return probe


@pytest.mark.parametrize("delay", [4.0, 2.5, 0.37])
def test_a_copied_turn_gives_back_its_delay(delay: float) -> None:
    measured = fed(delay).measure(18.0)
    assert measured is not None
    assert measured["delay_s"] == pytest.approx(delay, abs=0.02)
    assert measured["correlation"] > 0.99
    assert measured["motion_deg"] == pytest.approx(40.0, abs=0.5)


def test_no_movement_or_no_copy_gives_no_figure() -> None:
    still = DelayProbe()
    for k in range(600):
        still.captured(k / 60, 0.3)
        still.sent(k / 60, 0.3)
    assert still.measure(10.0) is None
    noise = np.random.default_rng(3).normal(0.0, 5.0, 500)
    assert fed(4.0, copy=noise).measure(18.0) is None


def test_a_copy_as_the_mirror_image_gives_back_its_delay_and_says_mirrored() -> None:
    """A condition whose ``mirror`` differs from the booth's sends the yaw negated."""
    sent = np.arange(0.0, 18.0, 1 / 25)
    measured = fed(0.0, copy=-turn(sent - 1.5)).measure(18.0)
    assert measured is not None
    assert measured["delay_s"] == pytest.approx(1.5, abs=0.02)
    assert (measured["mirrored"], measured["correlation"] < -0.99) == (True, True)
    assert fed(1.5).measure(18.0)["mirrored"] is False  # type: ignore[index]


def test_the_brows_raised_and_the_robots_are_reported_peak_to_peak() -> None:
    probe = DelayProbe()
    for k in range(120):
        probe.brow_captured(k / 60, 0.6 if 30 <= k < 60 else 0.0)
        probe.brow_sent(k / 60, 0.0)
    assert probe.brows(2.0) == {"captured": 0.6, "sent": 0.0}
    assert DelayProbe().brows(2.0) is None


@pytest.mark.parametrize(
    ("gain", "offset", "sign"), [(1.0, 0.0, 1), (0.5, 3.0, 1), (2.0, -4.0, -1)]
)
def test_the_copys_gain_on_the_head_turn_is_the_slope_at_the_delay(
    gain: float, offset: float, sign: int
) -> None:
    """The robot's turn over the participant's: the gain, whatever the robot's head rests
    at (a re-centred head) and on either side (mirrored)."""
    sent = np.arange(0.0, 18.0, 1 / 25)
    measured = fed(0.0, copy=sign * gain * turn(sent - 1.2) + offset).measure(18.0)
    assert measured is not None
    assert measured["gain"] == pytest.approx(gain, rel=0.02)
    assert measured["mirrored"] is (sign < 0)
