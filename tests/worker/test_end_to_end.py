"""Simulated phone (real Live Link UDP) -> worker -> Furhat Realtime API peer (WebSocket).

The peer must see the participant's movement ``delay`` later (a short delay keeps the test
fast; the default of 4.000 s is checked separately), with UPPER_SNAKE names and degrees,
head poses every tick and face parameters at 25 Hz, through garbage input.
"""

from __future__ import annotations

import socket
from collections.abc import Iterator
from dataclasses import replace

import pytest
import zmq

from chameleons.worker.frames import BLENDSHAPE_NAMES, upper_snake
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.worker.control_peer import ControlPeer
from tests.worker.furhat_peer import FurhatPeer, Received
from tests.worker.phone import Pose, SteppingPhone

DELAY = 0.5
TICK = 1 / 125
POSES = [Pose(0.0, 0.0, 0.0), Pose(20.0, 5.0, 0.8), Pose(-15.0, 0.0, 0.1)]
STEPS = [0.0, 0.6, 1.6]
LOAD_SLACK = 0.25  # seconds a loaded machine may add to the delay, not take from it


@pytest.fixture
def zmq_context() -> Iterator[zmq.Context[zmq.Socket[bytes]]]:
    ctx: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    yield ctx
    ctx.term()


def _first_after(messages: list[Received], since: float, test: object) -> Received:
    assert callable(test)
    return next(m for m in messages if m.time >= since and test(m.message))


def _send_garbage(port: int) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        for packet in (b"", b"\x06", b"\x07" + bytes(300), b"garbage" * 40, bytes(2000)):
            sock.sendto(packet, ("127.0.0.1", port))


@pytest.mark.slow
def test_the_robot_copies_the_face_delay_seconds_later(
    zmq_context: zmq.Context[zmq.Socket[bytes]],
) -> None:
    control = ControlPeer(zmq_context)
    config = WorkerConfig(
        booth="e2e", driver="furhat", behaviour="copy", copy_delay=DELAY, mirror=False,
        head_recentre=False,  # the head as captured: its exact size and delay are tested
        livelink_port=0, facecapturex_port=None, capture_host="127.0.0.1",
        command_endpoint=control.command_endpoint, telemetry_endpoint=control.telemetry_endpoint,
    )  # fmt: skip
    with FurhatPeer() as robot:
        worker = Worker(replace(config, robot_url=robot.url), context=zmq_context).start()
        try:
            port = worker.receivers["livelink"].port
            with SteppingPhone(port, POSES, STEPS) as phone:
                robot.wait_for(lambda p: 1 in phone.sent_at, timeout=10)
                _send_garbage(port)
                robot.wait_for(lambda p: 2 in phone.sent_at, timeout=10)
                step2 = phone.sent_at[2]
                robot.wait_for(lambda p: any(r.time > step2 + DELAY + 0.3
                                             for r in p.received), timeout=10)  # fmt: skip
            drops = worker.ingest_stats()["drops"]
        finally:
            worker.stop()
    control.close()
    heads, faces = robot.of_type("request.face.headpose"), robot.of_type("request.face.params")
    step1, step2 = phone.sent_at[1], phone.sent_at[2]

    # Head: the filtered yaw crosses half the step DELAY after the participant moved. Never
    # earlier; later only by what a busy machine adds between the phone, the worker and the
    # peer (77 ms was seen with the browser tests running on 2 cores): the bound still tells
    # DELAY from no delay or twice it. The realised delay on a quiet machine (within 1 ms at
    # p99) is bench/worker_bench.py's figure.
    crossing = _first_after(heads, step1, lambda m: m["yaw"] > 10.0)
    assert DELAY - 0.06 <= crossing.time - step1 <= DELAY + LOAD_SLACK
    settled = _first_after(heads, step1 + DELAY + 0.2 + LOAD_SLACK, lambda m: True).message
    assert settled["yaw"] == pytest.approx(20.0, abs=0.1)  # degrees, same side
    assert settled["pitch"] == pytest.approx(5.0, abs=0.1)
    assert settled["relative"] is False
    back = _first_after(heads, step2, lambda m: m["yaw"] < 2.5)  # half way back to -15
    assert DELAY - 0.06 <= back.time - step2 <= DELAY + LOAD_SLACK  # garbage came in between

    # Face: JAW_OPEN steps too (face parameters every 40 ms, unfiltered).
    opened = _first_after(faces, step1, lambda m: m["params"]["JAW_OPEN"] > 0.4)
    assert -0.02 < opened.time - step1 - DELAY < LOAD_SLACK
    assert set(opened.message["params"]) == {upper_snake(n) for n in BLENDSHAPE_NAMES[:-1]}
    # The first face message past the step may fall between two captured frames (the copy
    # interpolates); the next one, a phone frame later and more, holds the new value.
    after_step = _first_after(faces, opened.time + 0.03, lambda m: True).message
    assert after_step["params"]["JAW_OPEN"] == pytest.approx(0.8, abs=0.01)

    # Rates over one second of copying: head pose every tick (125 Hz), face parameters at
    # 25 Hz. Never more; fewer only by the ticks a busy machine misses (76 head poses were
    # seen at load 12 on 2 cores): the lower bounds only tell a tick rate from a face rate.
    # The rates and their jitter on a quiet machine are bench/worker_bench.py's figures.
    window = (step1 + DELAY, step1 + DELAY + 1.0)
    in_window = [h for h in heads if window[0] <= h.time < window[1]]
    face_count = sum(window[0] <= f.time < window[1] for f in faces)
    assert 50 <= len(in_window) <= 126
    assert 10 <= face_count <= 26
    assert sum(drops.values()) >= 4  # the garbage was counted and dropped
