"""``virtual+furhat``: the robot switched to wakes from its neutral (drivers.switch). Two
real record drivers stand in for the display and the Furhat (each writes what it was sent
to a JSON-lines file); the switch driver's clock is a fake one the test moves."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from chameleons.worker.config import WorkerConfig
from chameleons.worker.drivers import DriverOptions, create_driver
from chameleons.worker.drivers.record import RecordDriver
from chameleons.worker.drivers.switch import SwitchDriver
from chameleons.worker.frames import N_BLENDSHAPES

HOLD, FADE = 0.45, 0.3
YAW, PITCH, ROLL = 20.0, -8.0, 4.0


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def sent(path: Path, kind: str) -> list[dict[str, Any]]:
    lines = path.read_text(encoding="utf-8").splitlines()
    return [r for r in map(json.loads, lines) if r["type"] == kind]


@pytest.fixture
def booth(tmp_path: Path) -> tuple[SwitchDriver, Clock, Path, Path]:
    clock = Clock()
    display, furhat = tmp_path / "display.jsonl", tmp_path / "furhat.jsonl"
    driver = SwitchDriver(RecordDriver(display), RecordDriver(furhat),
                          hold_seconds=HOLD, fade_seconds=FADE, clock=clock)  # fmt: skip
    driver.start()
    return driver, clock, display, furhat


def frame(driver: SwitchDriver, value: float = 0.5) -> None:
    driver.send_head(YAW, PITCH, ROLL)
    driver.send_face(np.full(N_BLENDSHAPES, value, dtype=np.float32))


def test_the_robot_switched_to_holds_its_neutral_then_fades_into_its_frames(
    booth: tuple[SwitchDriver, Clock, Path, Path],
) -> None:
    driver, clock, display, furhat = booth
    frame(driver)  # the display, driven from the start: no wake
    driver.set_face("face-1", "furhat")
    for seconds in (0.0, 0.2, HOLD - 0.01, HOLD + FADE / 2, HOLD + FADE, HOLD + FADE + 1.0):
        clock.now = 100.0 + seconds
        frame(driver)
    driver.close()

    heads = [(h["yaw"], h["pitch"], h["roll"]) for h in sent(furhat, "head")]
    assert heads == [
        (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),  # held at its neutral
        pytest.approx((YAW / 2, PITCH / 2, ROLL / 2)),  # half way through the fade
        (YAW, PITCH, ROLL), (YAW, PITCH, ROLL),  # its frames as they come
    ]
    faces = [max(f["params"].values()) for f in sent(furhat, "face")]
    assert faces == [0.0, 0.0, 0.0, pytest.approx(0.25), 0.5, 0.5]
    # The display had its frame at full weight, then its rest (neutral) on the switch.
    assert [h["yaw"] for h in sent(display, "head")] == [YAW, 0.0]


def test_a_switch_back_during_a_wake_starts_the_wake_again(
    booth: tuple[SwitchDriver, Clock, Path, Path],
) -> None:
    driver, clock, display, _ = booth
    driver.set_face("face-1", "furhat")
    clock.now += HOLD + FADE / 2
    driver.set_face("face-1", "3d")  # back to the display half way through the fade
    frame(driver)
    clock.now += HOLD + FADE
    frame(driver)
    driver.close()
    # Its rest on the switch away, held at its neutral on the way back, then its frame.
    assert [h["yaw"] for h in sent(display, "head")] == [0.0, 0.0, YAW]


def test_the_same_robot_again_is_no_switch(
    booth: tuple[SwitchDriver, Clock, Path, Path],
) -> None:
    """A new face on the robot already driven (2d -> 3d on the display) does not wake it."""
    driver, _, display, _ = booth
    driver.set_face("face-2", "3d")
    frame(driver)
    driver.close()
    assert [h["yaw"] for h in sent(display, "head")] == [YAW]


def test_the_worker_gives_the_switch_its_crossfade_and_lookahead(tmp_path: Path) -> None:
    """A worker's hold outlasts the behaviour crossfade that comes with a switch (and the
    ticks the renderer runs ahead), and its fade is as long as a crossfade."""
    config = WorkerConfig(crossfade_seconds=0.5, lookahead_ticks=10)
    assert config.switch_hold_seconds > 0.5 + 10 / config.render.tick_rate
    assert config.switch_fade_seconds == 0.5
    options = DriverOptions(robot_url="ws://127.0.0.1:9", record_path=tmp_path / "r.jsonl",
                            switch_hold_seconds=config.switch_hold_seconds,
                            switch_fade_seconds=config.switch_fade_seconds)  # fmt: skip
    driver = create_driver("virtual+furhat", options, lambda message: None)
    assert isinstance(driver, SwitchDriver)
    assert (driver.hold_seconds, driver.fade_seconds) == (
        config.switch_hold_seconds, config.switch_fade_seconds)  # fmt: skip
