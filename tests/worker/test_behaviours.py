"""Behaviours: registry, still, copy (exact delay as a property), natural, crossfades."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from chameleons.worker.behaviours import (
    VECTOR_SIZE,
    Behaviour,
    BehaviourError,
    available_behaviours,
    create_behaviour,
    register_behaviour,
    registry,
)
from chameleons.worker.behaviours.clips import MotionClip, load_clip
from chameleons.worker.behaviours.copy import DEFAULT_DELAY, CopyBehaviour
from chameleons.worker.behaviours.history import ClockMapper
from chameleons.worker.behaviours.natural import NaturalBehaviour
from chameleons.worker.behaviours.router import BehaviourRouter, build_context
from chameleons.worker.frames import N_BLENDSHAPES, F32Array, FaceFrame

HEAD_YAW = N_BLENDSHAPES


def _frame(capture: float, value: float, receive_offset: float = 0.0) -> FaceFrame:
    frame = FaceFrame(capture, capture + receive_offset)
    frame.blendshapes[:] = np.clip(value, 0, 1)
    frame.head[:] = (value * 30, value * -10, value * 5)
    return frame


def _out() -> F32Array:
    return np.zeros(VECTOR_SIZE, dtype=np.float32)


def test_builtins_are_registered() -> None:
    assert {"still", "natural", "copy"} <= set(available_behaviours())


@pytest.fixture
def registry_restored() -> Iterator[None]:
    """The test's own behaviour leaves the process-wide registry as it found it: later
    tests in the same worker (the study's behaviour list, the generated study reference)
    see only the real behaviours."""
    before = dict(registry._registry)
    try:
        yield
    finally:
        registry._registry.clear()
        registry._registry.update(before)


@pytest.mark.usefixtures("registry_restored")
def test_a_registered_behaviour_is_created_by_name_without_touching_the_router() -> None:
    @register_behaviour("test-constant")
    class Constant(Behaviour):
        def sample(self, t: float, out: F32Array) -> float:
            out[:] = 0.5
            return math.nan

    router = BehaviourRouter(build_context(), 0.0)
    router.set_behaviour("test-constant", {}, 0.0)
    out = _out()
    router.sample(1.0, out)
    assert np.all(out == 0.5)


def test_unknown_behaviour_and_bad_params_are_clear_errors() -> None:
    context = build_context()
    with pytest.raises(BehaviourError, match="unknown behaviour 'dance'"):
        create_behaviour("dance", {}, context)
    with pytest.raises(BehaviourError, match="delay"):
        create_behaviour("copy", {"delay": "soon"}, context)
    with pytest.raises(BehaviourError, match="speed: unknown parameter"):
        create_behaviour("copy", {"speed": 2}, context)
    with pytest.raises(BehaviourError, match="takes no parameters"):
        create_behaviour("still", {"x": 1}, context)
    with pytest.raises(BehaviourError, match="natural needs a 'path'"):
        create_behaviour("natural", {}, context)  # never a silent synthetic stand-in


def test_copy_default_delay_is_four_seconds() -> None:
    assert DEFAULT_DELAY == 4.0
    behaviour = create_behaviour("copy", {}, build_context())
    assert isinstance(behaviour, CopyBehaviour)
    assert behaviour.delay == 4.000


def test_copy_is_neutral_until_the_delay_has_elapsed() -> None:
    context = build_context(recentre_head=False)  # the head exactly as captured
    router = BehaviourRouter(context, 0.0, initial="copy", params={"delay": 1.0})
    for k in range(120):
        router.on_participant(_frame(10 + k / 60, 0.8))
    out = _out()
    assert math.isnan(router.sample(10.99, out))
    assert not out.any()
    router.sample(11.0, out)
    assert out[HEAD_YAW] == pytest.approx(24.0)


@settings(max_examples=60, deadline=None)
@given(
    delay=st.floats(0.0, 5.0),
    offset=st.floats(-1000.0, 1000.0),
    rate=st.sampled_from([30.0, 59.94, 60.0]),
    values=st.lists(st.floats(-1.0, 2.0), min_size=2, max_size=80),
    query=st.floats(0.0, 1.0),
)
def test_copy_output_at_t_is_input_interpolated_at_t_minus_delay(
    delay: float, offset: float, rate: float, values: list[float], query: float
) -> None:
    """The property: output(t) == lerp(input, t - delay) on the mapped capture clock (the
    head as captured: without re-centring on the participant's neutral pose)."""
    context = build_context(recentre_head=False)
    router = BehaviourRouter(context, 0.0, initial="copy", params={"delay": delay})
    captures = 100 + np.arange(len(values)) / rate  # the sender's clock
    for capture, value in zip(captures, values, strict=True):
        router.on_participant(_frame(capture, value, receive_offset=offset))
    local = captures + offset  # constant transport delay: the mapping is exact
    t = local[0] + delay + query * (local[-1] - local[0])
    out = _out()
    router.sample(t, out)
    yaw_in = np.array(values) * 30
    expected = np.interp(t - delay, local, yaw_in)
    assert out[HEAD_YAW] == pytest.approx(expected, abs=1e-3)
    shape_in = np.clip(values, 0, 1)
    assert out[0] == pytest.approx(np.interp(t - delay, local, shape_in), abs=1e-5)


def test_clock_mapper_uses_the_least_delayed_frame_and_resets_on_jumps() -> None:
    mapper = ClockMapper(window_seconds=10)
    assert mapper.to_local(0.0, 5.030) == pytest.approx(5.030)
    assert mapper.to_local(0.1, 5.110) == pytest.approx(5.110)  # less delayed: new offset
    assert mapper.to_local(0.2, 5.250) == pytest.approx(5.210)  # late frame: old offset
    assert mapper.to_local(500.0, 9.0) == pytest.approx(9.0)  # sender clock restarted
    assert mapper.resets == 0  # offset fell: adopted at once without a reset
    assert mapper.to_local(1.0, 9.5) == pytest.approx(9.5)
    assert mapper.resets == 1


@pytest.mark.parametrize("source", ["webcam-python", "webcam-browser"])
def test_a_webcam_frame_keeps_its_capture_time_its_tracking_time_is_not_added(
    source: str,
) -> None:
    """A webcam's capture time is on this host's clock already: the time spent tracking
    the frame (receive - capture) is not a clock offset to add to the copy delay."""
    router = BehaviourRouter(build_context(), 0.0, initial="copy", params={"delay": 0.5})
    frame = _frame(10.0, 0.5, receive_offset=0.008)
    frame.source = source
    assert router.on_participant(frame) == 10.0
    iphone = _frame(11.0, 0.5, receive_offset=0.008)  # a sender clock: the offset is mapped
    assert router.on_participant(iphone) == pytest.approx(11.008)


def test_history_is_bounded_and_holds_over_long_dropouts() -> None:
    context = build_context(history_seconds=1.0, max_input_rate=60)
    router = BehaviourRouter(context, 0.0, initial="copy", params={"delay": 0.5})
    for k in range(600):
        router.on_participant(_frame(k / 60, (k % 7) / 7))
    assert len(context.history) == 60
    router.on_participant(_frame(20.0, 1.0))  # after a 10 s dropout
    out = _out()
    router.sample(15.0 + 0.5, out)  # inside the gap: hold the frame before it
    assert out[0] == pytest.approx((599 % 7) / 7)


def _ramp_clip(duration: float = 4.0, rate: float = 30.0) -> MotionClip:
    times = np.arange(0, duration + 1e-9, 1 / rate)
    shapes = np.tile((times / duration)[:, None], (1, N_BLENDSHAPES))
    head = np.stack([times * 10, times, -times], axis=1)
    return MotionClip.from_arrays(times, shapes, head)


def test_natural_replays_from_the_offset_and_loops_without_jumps() -> None:
    clip = _ramp_clip()
    behaviour = NaturalBehaviour(build_context(), clip, offset=1.0)
    behaviour.start(50.0)
    out = _out()
    behaviour.sample(50.5, out)
    assert out[HEAD_YAW] == pytest.approx(15.0, abs=1e-3)  # clip time 1.5 s
    previous, biggest = None, 0.0
    for t in np.arange(50.0, 70.0, 1 / 125):
        behaviour.sample(float(t), out)
        if previous is not None:
            biggest = max(biggest, abs(float(out[HEAD_YAW]) - previous))
        previous = float(out[HEAD_YAW])
    # The ramp climbs 10 deg/s (0.08 per tick); the seam blend may double that, never jump.
    assert biggest < 0.5


def test_natural_loads_npz_clips(tmp_path) -> None:
    clip = _ramp_clip()
    path = tmp_path / "clip.npz"
    np.savez(path, times=clip.times, blendshapes=clip.vectors[:, :N_BLENDSHAPES],
             head=clip.vectors[:, N_BLENDSHAPES : N_BLENDSHAPES + 3])  # fmt: skip
    loaded = load_clip(path)
    np.testing.assert_allclose(loaded.vectors, clip.vectors)
    behaviour = create_behaviour("natural", {"path": str(path), "offset": 2.0}, build_context())
    assert behaviour.describe()["duration"] == pytest.approx(4.0)
    with pytest.raises(BehaviourError, match="not found"):
        create_behaviour("natural", {"path": str(tmp_path / "missing.npz")}, build_context())


@pytest.mark.parametrize("crossfade", [0.1, 0.3])
def test_switching_behaviour_never_jumps(crossfade: float) -> None:
    """Still (neutral) -> copy of a far-from-neutral face -> still, switching mid-fade too:
    the per-tick change stays within |difference| * tick / crossfade (the head as captured,
    not re-centred on the participant's neutral pose)."""
    router = BehaviourRouter(build_context(recentre_head=False), crossfade, initial="still")
    for k in range(60 * 6):
        router.on_participant(_frame(k / 60, 1.0))  # a constant, extreme face
    tick = 1 / 125
    switches = {1.0: ("copy", {"delay": 0.5}), 1.0 + crossfade / 2: ("still", {}),
                2.5: ("copy", {"delay": 1.0})}  # fmt: skip
    out = _out()
    previous: F32Array | None = None
    max_step = np.zeros(VECTOR_SIZE)
    for k in range(int(4.0 / tick)):
        t = 0.5 + k * tick
        for when, (name, params) in switches.items():
            if abs(t - when) < tick / 2:
                router.set_behaviour(name, params, t)
        router.sample(t, out)
        router.advance(t)
        if previous is not None:
            max_step = np.maximum(max_step, np.abs(out - previous))
        previous = out.copy()
    extreme = np.abs(_frame(0, 1.0).to_vector())
    assert np.all(max_step <= extreme * tick / crossfade * 1.01 + 1e-6)
    assert out[HEAD_YAW] == pytest.approx(30.0)  # ended up copying


def test_natural_without_a_recording_plays_a_synthetic_face() -> None:
    behaviour = create_behaviour("natural", {"seed": 3}, build_context())
    behaviour.start(0.0)
    out = _out()
    values = []
    for t in (0.0, 1.0, 2.0, 3.0):
        behaviour.sample(t, out)
        values.append(out.copy())
    assert behaviour.describe()["source"] == "synthetic:3"
    assert np.ptp(np.array(values)[:, HEAD_YAW]) > 0.1  # it moves


def test_copy_undoes_the_neutral_pose_as_a_rotation_not_angle_by_angle() -> None:
    """A phone 14.7 degrees below the face reads a 40 degree turn as yaw 40.9, pitch 11.2,
    roll 9.6. Re-centred on the resting pose the copy shows the turn alone: no roll the
    participant never made (subtracting per angle would leave 9.6 degrees of it)."""
    from chameleons.worker.ingest.rotation import rotation_matrix, yaw_pitch_roll

    phone = rotation_matrix(0.0, 14.7, 0.0)  # the camera's tilt, applied to every reading
    context = build_context(head_calibration_s=1.0)
    router = BehaviourRouter(context, 0.0, initial="copy", params={"delay": 0.5})
    for k in range(120):  # 2 s at rest: the neutral freezes after 1 s
        frame = FaceFrame(k / 60, k / 60)
        frame.head[:] = yaw_pitch_roll(phone @ rotation_matrix(0.0, 0.0, 0.0))
        router.on_participant(frame)
    turned = FaceFrame(2.0, 2.0)
    turned.head[:] = yaw_pitch_roll(phone @ rotation_matrix(40.0, 0.0, 0.0))
    router.on_participant(turned)
    assert turned.head[2] == pytest.approx(9.6, abs=0.1)  # what the phone reads
    out = _out()
    router.sample(2.5, out)
    np.testing.assert_allclose(out[HEAD_YAW : HEAD_YAW + 3], [40.0, 0.0, 0.0], atol=0.01)
    router.sample(1.9, out)  # at rest: straight ahead
    np.testing.assert_allclose(out[HEAD_YAW : HEAD_YAW + 3], [0.0, 0.0, 0.0], atol=0.01)
    assert context.head_neutral.describe()["pose"] == {"yaw": 0.0, "pitch": 14.7, "roll": 0.0}


def test_a_fresh_neutral_measures_only_frames_captured_after_the_restart() -> None:
    """A frame of the person before, captured before the restart but reaching the behaviour
    stage after it (still in a queue), is not part of the new participant's neutral."""
    from chameleons.worker.behaviours.neutral import HeadNeutral

    neutral = HeadNeutral(calibration_s=0.5)
    for k in range(60):  # someone else, before
        neutral.add(k / 60, np.array([0.0, -10.0, 0.0], dtype=np.float32))
    neutral.restart(since=1.0)
    neutral.add(0.99, np.array([0.0, -10.0, 0.0], dtype=np.float32))  # late, from before
    for k in range(60, 120):
        neutral.add(k / 60, np.array([0.0, 14.7, 0.0], dtype=np.float32))
    described = neutral.describe()
    assert described["frozen"] is True
    assert described["pose"] == {"yaw": 0.0, "pitch": 14.7, "roll": 0.0}
    assert described["frames"] == 31  # 1.0 .. 1.5 s at 60 fps, the late frame left out
