"""One booth, two robots (the ``embodiment`` template within a session): a real worker with
``--driver virtual+furhat`` copies the participant (Live Link Face over UDP in) on the
virtual display while the condition's renderer is 2d or 3d, and on the Furhat (its test
peer) when it is ``furhat``; the robot left is set to its neutral head, and the robot
switched to wakes from its own neutral, in what it shows and in the robot's recording. A
worker without a Furhat refuses a furhat condition in one sentence."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zmq

from chameleons.worker.control import SET_FACE, START_RECORDING, STOP_RECORDING
from chameleons.worker.recording import read_recording_table
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.worker.control_peer import ControlPeer
from tests.worker.furhat_peer import FurhatPeer
from tests.worker.head_stream import Pose, stream, stream_after

pytestmark = pytest.mark.slow
BOOTH = "embodiment"
DELAY = 0.3
TURN = 30.0
REST = 10.0


@pytest.fixture
def context() -> Iterator[zmq.Context[zmq.Socket[bytes]]]:
    ctx: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    yield ctx
    ctx.term()


def start(context: zmq.Context[zmq.Socket[bytes]], server: ControlPeer, driver: str,
          robot_url: str, **more: Any) -> Worker:  # fmt: skip
    config = WorkerConfig(booth=BOOTH, driver=driver, robot_url=robot_url, behaviour="copy",
                          copy_delay=DELAY, mirror=False, head_recentre=False,
                          livelink_port=0, facecapturex_port=None, capture_host="127.0.0.1",
                          command_endpoint=server.command_endpoint,
                          telemetry_endpoint=server.telemetry_endpoint, **more)  # fmt: skip
    return Worker(config, context=context).start()


def display_yaws(server: ControlPeer, since: float) -> list[float]:
    return [float(m.body["yaw"]) for m in server.published
            if m.topic == f"display.{BOOTH}" and m.type == "head" and m.time >= since]  # fmt: skip


def furhat_yaws(robot: FurhatPeer, since: float) -> list[float]:
    return [float(r.message["yaw"]) for r in robot.of_type("request.face.headpose")
            if r.time >= since]  # fmt: skip


def turn(worker: Worker) -> float:
    """The participant, resting 10 deg to the side, turns 30 deg further and back; returns
    when the copy is over (monotonic)."""
    pose = Pose(rest_yaw=REST, turn_at=0.3, turn_deg=TURN)
    sent = stream(worker.receivers["livelink"].port, pose, 1.8)
    return sent.start + 1.8 + DELAY + 0.3


def test_the_condition_renderer_chooses_the_robot_that_copies(
    context: zmq.Context[zmq.Socket[bytes]],
) -> None:
    server = ControlPeer(context)
    with FurhatPeer() as robot:
        worker = start(context, server, "virtual+furhat", robot.url)
        try:
            robot.wait_for(lambda p: bool(p.of_type("request.face.config")), timeout=10)
            on_display = server.command(BOOTH, SET_FACE, {"face_id": "f1", "renderer": "2d"})
            assert on_display.ok, on_display
            before = time.monotonic()
            done = turn(worker)
            server.wait(lambda: any(m.time > done for m in server.published), timeout=10)
            peak = REST + TURN
            assert max(map(abs, display_yaws(server, before))) == pytest.approx(peak, abs=2.0)
            assert max(map(abs, furhat_yaws(robot, before)), default=0.0) < 0.5

            on_furhat = server.command(BOOTH, SET_FACE, {"face_id": "f1", "renderer": "furhat"})
            assert on_furhat.ok, on_furhat
            assert on_furhat.result["renderer"] == "furhat"
            switched = time.monotonic()
            done = turn(worker)
            robot.wait_for(lambda p: bool(furhat_yaws(robot, done)), timeout=10)
            assert max(map(abs, furhat_yaws(robot, switched))) == pytest.approx(peak, abs=2.0)
            beat: dict[str, Any] = server.wait(lambda: next(
                (m.body for m in server.of_type("heartbeat") if m.time > done), None),
                timeout=10)  # fmt: skip
            assert beat["driver"] == "virtual+furhat"
            assert beat["robot_connected"] is True  # the driven robot's (the Furhat's) state
            # Which robot is driven, and each one's state (the console's health reads them).
            assert beat["robot_active"] == "furhat"
            assert {name: o["state"] for name, o in beat["robot_outputs"].items()} == {
                "display": "connected", "furhat": "connected"}  # fmt: skip
            # (The heartbeat came after the copy: what the display was sent has arrived.)
            # The display was set to its neutral head on the switch (the participant rests
            # 10 deg aside), and is not driven since.
            assert abs(display_yaws(server, before)[-1]) < 0.5
            assert display_yaws(server, switched + 0.5) == []
        finally:
            worker.stop()
            server.close()


def test_the_robot_switched_to_wakes_from_its_neutral_and_is_recorded_so(
    context: zmq.Context[zmq.Socket[bytes]], tmp_path: Path,
) -> None:
    """The participant rests 10 deg aside, which the copy shows on the display; on a switch
    the Furhat does not take that pose at once but holds its neutral, then fades into it,
    and the robot's recording (what was sent) says the same."""
    server = ControlPeer(context)
    with FurhatPeer() as robot:
        worker = start(context, server, "virtual+furhat", robot.url, data_dir=tmp_path)
        hold, fade = worker.config.switch_hold_seconds, worker.config.switch_fade_seconds
        crossfade = worker.config.crossfade_seconds  # the hold outlasts it (at least)
        done = threading.Event()  # the participant rests until the test has seen enough
        sender = threading.Thread(target=stream_after, args=(
            worker.receivers["livelink"].port, Pose(rest_yaw=REST), 0.1, lambda: True),
            kwargs={"until": done.is_set})  # fmt: skip
        try:
            robot.wait_for(lambda p: bool(p.of_type("request.face.config")), timeout=10)
            recording = {"interaction_id": 1, "directory": str(tmp_path)}
            assert server.command(BOOTH, START_RECORDING, recording).ok
            sender.start()
            server.wait(lambda: len([y for y in display_yaws(server, 0.0)
                                     if abs(y) > REST - 0.5]) >= 20,
                        timeout=10)  # the display has copied the rest for a while  # fmt: skip
            asked = time.monotonic()
            assert server.command(BOOTH, SET_FACE, {"face_id": "f1", "renderer": "furhat"}).ok
            robot.wait_for(lambda p: bool(furhat_yaws(robot, asked + hold + fade + 0.5)),
                           timeout=10)  # fmt: skip
            done.set()
            sender.join()
            stopped = server.command(BOOTH, STOP_RECORDING, {"interaction_id": 1})
            assert stopped.ok, stopped
        finally:
            done.set()
            worker.stop()
            server.close()

    furhat = [(r.time, float(r.message["yaw"])) for r in robot.of_type("request.face.headpose")
              if r.time >= asked]  # fmt: skip
    first = furhat[0][0]
    assert max(abs(y) for t, y in furhat if t < first + crossfade) < 0.5  # its neutral
    awake = [y for t, y in furhat if t > first + hold + fade + 0.2]  # then the copied rest
    assert awake
    assert awake == pytest.approx([REST] * len(awake), abs=1.0)
    # The robot's recording: the copied rest, then the switched robot's neutral and wake.
    table = read_recording_table(stopped.result["files"]["agent"])
    rows = list(zip(table.column("capture_time").to_pylist(),
                    table.column("head_yaw").to_pylist(), strict=True))  # fmt: skip
    before = [abs(y) for t, y in rows if t < asked - 0.1]
    assert before
    assert before[-1] == pytest.approx(REST, abs=1.0)
    switched = next(t for t, y in rows if t >= asked and abs(y) < 0.5)
    assert max(abs(y) for t, y in rows if switched <= t < switched + crossfade - 0.1) < 0.5
    assert abs(next(y for t, y in rows if t > switched + hold + fade + 0.1)) == pytest.approx(
        REST, abs=1.0)


def test_a_booth_without_a_furhat_refuses_a_furhat_condition(
    context: zmq.Context[zmq.Socket[bytes]],
) -> None:
    server = ControlPeer(context)
    worker = start(context, server, "virtual", "ws://127.0.0.1:9")
    try:
        ack = server.command(BOOTH, SET_FACE, {"face_id": "f1", "renderer": "furhat"})
        assert not ack.ok
        assert ack.error == "bad_renderer"
        assert ack.detail == ("this booth drives no Furhat (its worker's driver is virtual): a "
                              "furhat condition needs a worker started with --driver furhat "
                              "or --driver virtual+furhat")  # fmt: skip
        assert server.command(BOOTH, SET_FACE, {"face_id": "f1", "renderer": "3d"}).ok
    finally:
        worker.stop()
        server.close()
