"""The renderer: FIR design, mixing, face/head rates, deadline scheduling."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest
from scipy.signal import firwin

from chameleons.worker.behaviours import VECTOR_SIZE
from chameleons.worker.drivers.base import Driver
from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES, F32Array
from chameleons.worker.lipsync import LipSync
from chameleons.worker.renderer import (
    MOUTH_JAW,
    HeadFilter,
    RenderConfig,
    RenderCore,
    RenderLoop,
)

YAW = N_BLENDSHAPES


class CountingDriver(Driver):
    """A real driver that keeps what it was sent (the null driver keeps only counts)."""

    name = "counting"

    def __init__(self) -> None:
        super().__init__()
        self.faces: list[F32Array] = []
        self.heads: list[tuple[float, float, float]] = []

    def send_face(self, blendshapes: F32Array) -> None:
        self.faces.append(blendshapes.copy())

    def send_head(self, yaw: float, pitch: float, roll: float) -> None:
        self.heads.append((yaw, pitch, roll))


def _vector(yaw: float = 0.0, shapes: float = 0.0) -> F32Array:
    vector = np.full(VECTOR_SIZE, shapes, dtype=np.float32)
    vector[N_BLENDSHAPES:] = 0
    vector[YAW] = yaw
    return vector


def test_fir_is_designed_once_with_firwin_and_reports_its_group_delay() -> None:
    head = HeadFilter(15, 6.0, 125.0)
    np.testing.assert_allclose(head.taps, firwin(15, 6.0, fs=125.0))
    assert head.group_delay == pytest.approx(7 / 125)
    assert HeadFilter(1, 6.0, 125.0).group_delay == 0.0


def test_fir_is_linear_phase_a_ramp_comes_out_group_delay_late() -> None:
    head = HeadFilter(21, 5.0, 125.0)
    outputs = [head.push(np.array([k, 0, 0], dtype=np.float32))[0] for k in range(100)]
    # After the start-up transient a ramp is delayed by exactly (taps - 1) / 2 samples.
    assert outputs[-1] == pytest.approx(99 - 10, abs=1e-6)
    assert outputs[0] == 0.0  # primed with the first pose: no ramp out of zero


@pytest.mark.parametrize(("tick_rate", "face_rate"), [(125.0, 25.0), (125.0, 125.0), (100, 30)])
def test_head_every_tick_and_face_at_the_face_rate(tick_rate: float, face_rate: float) -> None:
    driver = CountingDriver()
    core = RenderCore(driver, RenderConfig(tick_rate=tick_rate, face_rate=face_rate))
    seconds = 4
    for k in range(int(seconds * tick_rate)):
        core.tick(k / tick_rate)
    assert len(driver.heads) == seconds * tick_rate
    assert len(driver.faces) == pytest.approx(seconds * face_rate, abs=1)


def test_ticks_interpolate_between_keyframes_and_hold_past_the_newest() -> None:
    driver = CountingDriver()
    core = RenderCore(driver, RenderConfig(fir_taps=1))
    core.push_keyframe(10.0, _vector(yaw=0.0), input_time=6.0)
    core.push_keyframe(10.008, _vector(yaw=8.0), input_time=6.008)
    assert core.tick(10.004) == pytest.approx(6.004)  # the input this output stands for
    assert driver.heads[-1][0] == pytest.approx(4.0)
    core.tick(10.1)
    assert driver.heads[-1][0] == pytest.approx(8.0)
    assert core.underruns == 1


def test_no_keyframes_means_a_neutral_face() -> None:
    driver = CountingDriver()
    core = RenderCore(driver)
    core.tick(1.0)
    assert driver.heads == [(0.0, 0.0, 0.0)]
    assert not driver.faces[0].any()


def test_lipsync_owns_mouth_and_jaw_while_speaking_on_the_audio_clock() -> None:
    driver = CountingDriver()
    core = RenderCore(driver, RenderConfig(face_rate=125.0, lipsync_fade=0.02))
    jaw = BLENDSHAPE_INDEX["jawOpen"]
    curve = LipSync.from_arrays([0.0, 1.0], {"jawOpen": [0.0, 1.0]})
    for k in range(500):
        core.push_keyframe(k / 125, _vector(shapes=0.3), input_time=k / 125)
    core.lipsync.load("p1", curve)
    core.tick(0.5)
    assert driver.faces[-1][jaw] == pytest.approx(0.3)  # pending until the audio starts
    core.lipsync.begin(1.0)
    core.tick(1.5)
    face = driver.faces[-1]
    assert face[jaw] == pytest.approx(0.5)
    assert face[MOUTH_JAW.start] == pytest.approx(0.0)  # an absent channel: closed
    assert face[BLENDSHAPE_INDEX["eyeBlinkLeft"]] == pytest.approx(0.3)  # not lip-sync's
    core.lipsync.finish(1.6)
    core.tick(1.7)
    assert driver.faces[-1][jaw] == pytest.approx(0.3)
    assert not core.lipsync.active


class FakeClock:
    def __init__(self, start: float = 100.0) -> None:
        self.now = start

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


def test_loop_ticks_on_deadlines_and_counts_missed_ticks() -> None:
    clock = FakeClock()
    due_times: list[float] = []

    def on_tick(due: float, now: float) -> None:
        due_times.append(due)
        if len(due_times) == 10:
            clock.now += 0.030  # a stall of 3.75 periods: deadlines 11 and 12 pass

    loop = RenderLoop(125.0, on_tick, clock=clock, sleep=clock.sleep)
    loop.run(threading.Event(), max_ticks=100)
    steps = np.round(np.diff(due_times) * 125).astype(int)
    assert set(steps) == {1, 3}  # every deadline, except the two skipped in the stall
    assert loop.stats.missed == 2
    assert all(abs(d * 125 - round(d * 125)) < 1e-6 for d in due_times)  # on the grid


def test_real_loop_runs_at_the_tick_rate_until_stopped() -> None:
    stop, done = threading.Event(), threading.Event()
    driver = CountingDriver()
    core = RenderCore(driver)

    def on_tick(due: float, now: float) -> None:
        core.tick(due)
        if len(driver.heads) >= 50:
            done.set()
            stop.set()

    loop = RenderLoop(125.0, on_tick)
    thread = threading.Thread(target=loop.run, args=(stop,))
    thread.start()
    assert done.wait(5)
    thread.join(5)
    assert len(driver.heads) == 50
    assert len(driver.faces) == 10
    summary = loop.stats.summary()
    assert summary["ticks"] == 50
    # How small the jitter is depends on the machine's load: bench/ measures it. Here only
    # that the loop reports it.
    assert math.isfinite(summary["jitter_p50_ms"])
    assert summary["jitter_p50_ms"] >= 0.0


def test_skipped_ticks_still_feed_the_head_filter_so_its_delay_holds() -> None:
    """A ramp through the filter comes out group-delay late even when ticks were skipped."""
    driver = CountingDriver()
    core = RenderCore(driver, RenderConfig(fir_taps=15))
    ticks = [k for k in range(300) if not 100 <= k % 120 < 110]  # 10 ticks skipped at a time
    for k in range(300):
        core.push_keyframe((k + 5) / 125, _vector(yaw=k + 5), input_time=k / 125)  # ahead
        if k in ticks:
            core.tick(k / 125)
    yaw = [head[0] for head in driver.heads]
    lag = [k - y for k, y in zip(ticks, yaw, strict=True)]
    assert all(value == pytest.approx(7, abs=1e-3) for value in lag[20:])
