"""``copy``'s design-space parameters through a real behaviour stage (inproc ZeroMQ): the
participant's frames go in on the participant bus, the agent's keyframes come out."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zmq

from chameleons.worker.behaviour_stage import BehaviourStage, BehaviourStageConfig
from chameleons.worker.behaviours.copy import CopyBehaviour
from chameleons.worker.behaviours.copy_timing import RAMP, BoutSchedule, DelaySchedule
from chameleons.worker.envelope import Message, deserialize, frame_message, serialize
from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES, FaceFrame
from chameleons.worker.stage import Endpoints

Context = zmq.Context[zmq.Socket[bytes]]
YAW = N_BLENDSHAPES
BROW = BLENDSHAPE_INDEX["browInnerUp"]
BROW_LEFT, BROW_RIGHT = BLENDSHAPE_INDEX["browOuterUpLeft"], BLENDSHAPE_INDEX["browOuterUpRight"]
SMILE = BLENDSHAPE_INDEX["mouthSmileLeft"]


@pytest.fixture
def zmq_context() -> Iterator[Context]:
    ctx: Context = zmq.Context()
    yield ctx
    ctx.term()


def turned_face(now: float) -> FaceFrame:
    """The participant holds a head turn (20 deg yaw), raised brows (left more) and a smile."""
    frame = FaceFrame(now, now)
    frame.head[0] = 20.0
    frame.blendshapes[BROW] = 0.8
    frame.blendshapes[BROW_LEFT] = 0.6
    frame.blendshapes[SMILE] = 0.5
    return frame


def run_copy(
    context: Context, params: Mapping[str, Any], *, enough: Callable[[list[Message]], bool],
    face: Callable[[float], FaceFrame] = turned_face, mirror: bool = True, timeout: float = 20.0,
    behaviour: str = "copy",
) -> tuple[list[Message], BehaviourStage]:  # fmt: skip
    """Send the participant's face every 10 ms to a behaviour stage running ``copy`` with
    ``params`` until ``enough`` of its keyframes have come out."""
    endpoints = Endpoints.inproc(f"copy-design-{time.monotonic_ns()}")
    stage = BehaviourStage(context, endpoints, BehaviourStageConfig(
        initial=behaviour, initial_params=params, recentre_head=False, mirror=mirror,
        crossfade_seconds=0.0))  # fmt: skip
    participant = context.socket(zmq.PUB)
    participant.bind(endpoints.participant)
    hub = context.socket(zmq.ROUTER)
    hub.bind(endpoints.stage_control)
    agent = context.socket(zmq.SUB)
    agent.setsockopt(zmq.SUBSCRIBE, b"face.agent")
    stop = threading.Event()
    thread = threading.Thread(target=stage.run, args=(stop,))
    thread.start()
    keyframes: list[Message] = []
    try:
        agent.connect(endpoints.agent)
        deadline = time.monotonic() + timeout
        seq = 0
        while not enough(keyframes):
            assert time.monotonic() < deadline, f"only {len(keyframes)} keyframes came out"
            now = time.monotonic()
            seq += 1
            participant.send_multipart(serialize(frame_message(
                face(now), "face.participant", seq=seq, source="t", time=now)))  # fmt: skip
            while agent.poll(10):  # also paces the frames: one per 10 ms at most
                keyframes.append(deserialize(agent.recv_multipart()))
    finally:
        stop.set()
        thread.join(5)
        for socket in (participant, hub, agent):
            socket.close(linger=0)
    return keyframes, stage


def copied(keyframes: list[Message]) -> list[np.ndarray]:
    return [m.array() for m in keyframes if m.body["input_time"] is not None]


def settled(count: int) -> Callable[[list[Message]], bool]:
    """Enough once ``count`` keyframes copied the held face."""
    return lambda keyframes: len(copied(keyframes)) >= count


def last_copy(context: Context, params: Mapping[str, Any], **options: Any) -> np.ndarray:
    keyframes, _ = run_copy(context, {"delay": 0.05, **params}, enough=settled(30), **options)
    return copied(keyframes)[-1]


def test_head_only_copies_the_head_turn_but_not_the_brows(zmq_context: Context) -> None:
    out = last_copy(zmq_context, {"channels": "head"})
    assert out[YAW] == pytest.approx(20.0)
    assert out[BROW] == 0.0
    assert out[SMILE] == 0.0


def test_face_only_copies_the_brows_but_not_the_head_turn(zmq_context: Context) -> None:
    out = last_copy(zmq_context, {"channels": "face"})
    assert out[YAW] == 0.0
    assert out[BROW] == pytest.approx(0.8)
    assert out[SMILE] == pytest.approx(0.5)


def test_an_explicit_list_copies_just_those_channels(zmq_context: Context) -> None:
    out = last_copy(zmq_context, {"channels": ["HeadYaw", "mouthSmileLeft"]})
    assert out[YAW] == pytest.approx(20.0)
    assert out[SMILE] == pytest.approx(0.5)
    assert out[BROW] == 0.0


def test_gain_scales_every_channel_or_each_its_own(zmq_context: Context) -> None:
    half = last_copy(zmq_context, {"gain": 0.5})
    assert half[YAW] == pytest.approx(10.0)
    assert half[BROW] == pytest.approx(0.4)
    mixed = last_copy(zmq_context, {"gain": {"head": 2.0, "brows": 0.25}})
    assert mixed[YAW] == pytest.approx(40.0)
    assert mixed[BROW] == pytest.approx(0.2)
    assert mixed[SMILE] == pytest.approx(0.5)
    capped = last_copy(zmq_context, {"gain": 3.0})
    assert capped[BROW] == 1.0  # a blendshape stays within 0..1


def test_a_condition_may_copy_the_same_side_where_the_booth_mirrors(zmq_context: Context) -> None:
    # The booth mirrors (frames arrive mirrored); this condition wants the same side back.
    out = last_copy(zmq_context, {"mirror": False}, mirror=True)
    assert out[YAW] == pytest.approx(-20.0)
    assert out[BROW_RIGHT] == pytest.approx(0.6)
    assert out[BROW_LEFT] == 0.0
    same = last_copy(zmq_context, {"mirror": True}, mirror=True)  # as the booth: unchanged
    assert same[YAW] == pytest.approx(20.0)
    assert same[BROW_LEFT] == pytest.approx(0.6)


def test_only_smiles_copies_the_smile_and_nothing_else(zmq_context: Context) -> None:
    out = last_copy(zmq_context, {"only": ["smiles"]})
    assert out[SMILE] == pytest.approx(0.5)
    assert out[YAW] == 0.0
    assert out[BROW] == 0.0

    # A smile below the threshold (0.3) is not copied.
    def faint(now: float) -> FaceFrame:
        frame = turned_face(now)
        frame.blendshapes[SMILE] = 0.2
        return frame

    assert last_copy(zmq_context, {"only": ["smiles"]}, face=faint)[SMILE] == 0.0


def test_coexpress_copies_at_zero_lag(zmq_context: Context) -> None:
    keyframes, stage = run_copy(zmq_context, {"coexpress": True}, enough=settled(20))
    assert [m.body["lag"] for m in keyframes if m.body["input_time"] is not None][-1] == 0.0
    assert isinstance(stage.router.current, CopyBehaviour)
    assert stage.router.current.delay == 0.0


def test_intermittent_copies_in_bouts_on_the_seeded_schedule(zmq_context: Context) -> None:
    params = {"delay": 0.05, "intermittent": {"rate_per_s": 2.0, "bout_s": 0.4}, "seed": 7}
    schedule = BoutSchedule(2.0, 0.4, seed=7)
    keyframes, stage = run_copy(zmq_context, params, enough=lambda ks: len(ks) >= 500)
    behaviour = stage.router.current
    assert isinstance(behaviour, CopyBehaviour)
    start = behaviour._start
    history_start = behaviour.context.history.first_time
    checked = inside = outside = 0
    for message in keyframes:
        t = message.body["t"]
        if t - 0.05 < history_start + 0.05:  # nothing (or the first frames) to copy yet
            continue
        weight = schedule.weight(t - start)
        assert message.array()[YAW] == pytest.approx(20.0 * weight, abs=1e-3)
        checked += 1
        inside += weight == 1.0
        outside += weight == 0.0
    assert checked > 300
    assert inside > 10
    assert outside > 10


def test_bout_statistics_match_the_configured_rate_and_length() -> None:
    rate, bout = 0.5, 1.5
    bouts = BoutSchedule(rate, bout, seed=3).bouts(until=40_000.0)
    lengths = np.array([end - onset for onset, end in bouts])
    rests = np.diff([0.0] + [onset for onset, _ in bouts]) - np.r_[0.0, lengths[:-1]]
    assert np.allclose(lengths, bout)
    assert len(bouts) > 8000
    assert rests.mean() == pytest.approx(1 / rate, rel=0.03)  # exponential, mean 1 / rate
    assert rests.std() == pytest.approx(1 / rate, rel=0.05)
    copying = lengths.sum() / bouts[-1][1]
    assert copying == pytest.approx(bout / (bout + 1 / rate), rel=0.03)
    # The ramp at a bout's edges is inside the bout: full weight from RAMP on.
    schedule = BoutSchedule(rate, bout, seed=3)
    onset = schedule.bouts(until=10.0)[0][0]
    assert schedule.weight(onset + RAMP) == 1.0
    assert schedule.weight(onset - 1e-6) == 0.0


def test_jittered_delays_are_seeded_and_within_the_distribution() -> None:
    uniform = DelaySchedule({"uniform": [0.5, 1.0]}, seed=1, resample_s=10.0, maximum=11.5)
    draws = np.array([uniform.draw(k) for k in range(4000)])
    assert draws.min() >= 0.5
    assert draws.max() <= 1.0
    assert draws.mean() == pytest.approx(0.75, abs=0.01)
    again = DelaySchedule({"uniform": [0.5, 1.0]}, seed=1, resample_s=10.0, maximum=11.5)
    other = DelaySchedule({"uniform": [0.5, 1.0]}, seed=2, resample_s=10.0, maximum=11.5)
    assert [again.draw(k) for k in range(5)] == list(draws[:5])
    assert [other.draw(k) for k in range(5)] != list(draws[:5])
    normal = DelaySchedule({"normal": {"mean": 0.7, "sd": 0.1}}, seed=1, resample_s=10.0,
                           maximum=11.5)  # fmt: skip
    values = np.array([normal.draw(k) for k in range(4000)])
    assert values.mean() == pytest.approx(0.7, abs=0.01)
    assert values.std() == pytest.approx(0.1, rel=0.1)
    # A new draw takes over every resample_s seconds, crossfaded from the previous one.
    assert uniform.at(25.0) == (draws[2], draws[2], 1.0)
    delay, previous, weight = uniform.at(20.15)
    assert (delay, previous) == (draws[2], draws[1])
    assert weight == pytest.approx(0.5)


def test_yoked_copy_replays_another_participant_at_the_same_delay(
    zmq_context: Context, tmp_path: Path
) -> None:
    """The recording's head sways around 5 deg yaw and smiles; the live participant holds a
    20 deg turn. Head only, 0.3 s late: the robot shows the recording's sway (re-centred on
    its own mean), never the live participant's turn, and not the recording's smile."""
    times = np.arange(0, 60, 1 / 30)
    head = np.zeros((len(times), 3))
    head[:, 0] = 5 + 10 * np.sin(np.pi * times)
    shapes = np.zeros((len(times), N_BLENDSHAPES))
    shapes[:, SMILE] = 0.4
    path = tmp_path / "other.npz"
    np.savez(path, times=times, blendshapes=shapes, head=head)
    params = {"path": str(path), "delay": 0.3, "channels": "head"}
    keyframes, stage = run_copy(zmq_context, params, behaviour="yoked_copy",
                                enough=lambda ks: len(ks) >= 250)  # fmt: skip
    behaviour = stage.router.current
    assert isinstance(behaviour, CopyBehaviour)  # yoked_copy is one, replaying a recording
    start = behaviour._start
    checked = 0
    for message in keyframes:
        u = message.body["t"] - start
        assert message.body["input_time"] is None  # not contingent on this participant
        out = message.array()
        assert out[SMILE] == 0.0
        if u < 0.3:
            assert out[YAW] == 0.0  # the delay: neutral until the recording's first frame
            continue
        assert out[YAW] == pytest.approx(10 * np.sin(np.pi * (u - 0.3)), abs=0.1)
        checked += 1
    assert checked > 150
