"""A Live Link Face recording in the app's exact format (generated: see
``tests.worker.livelink_recording``) replayed over real UDP through a real worker to the
Furhat test peer: the robot turns as far as the participant did, in degrees, so the
default unit (radians) is the app's; the face-lost packets are counted as ``no_face``."""

from __future__ import annotations

import socket
import time
from dataclasses import replace

import pytest

from chameleons.worker.runtime import Worker, WorkerConfig
from tests.worker.furhat_peer import FurhatPeer
from tests.worker.livelink_recording import FPS, head_turn_then_nod

DELAY = 0.3


def _replay(port: int, packets: list[bytes]) -> None:
    """At the app's rate, on the recording's own clock (not a fixed sleep per packet)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        start = time.monotonic()
        for k, packet in enumerate(packets):
            delay = start + k / FPS - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            sock.sendto(packet, ("127.0.0.1", port))


@pytest.mark.slow
def test_a_head_turn_and_nod_from_the_app_reach_the_robot_at_their_real_size() -> None:
    recording = head_turn_then_nod(turn_deg=40.0, nod_deg=15.0)
    config = WorkerConfig(
        booth="replay", driver="furhat", behaviour="copy", copy_delay=DELAY, mirror=False,
        head_recentre=False,  # the head as captured: its size in degrees is tested
        livelink_port=0, facecapturex_port=None, capture_host="127.0.0.1",
        command_endpoint="tcp://127.0.0.1:1", telemetry_endpoint="tcp://127.0.0.1:1",
    )  # fmt: skip
    with FurhatPeer() as robot:
        worker = Worker(replace(config, robot_url=robot.url)).start()
        try:
            robot.wait_for(lambda p: bool(p.of_type("request.face.config")), timeout=10)
            _replay(worker.receivers["livelink"].port, recording.packets)
            sent = time.monotonic()
            robot.wait_for(lambda p: any(r.time > sent + DELAY + 0.3 for r in p.received),
                           timeout=10)  # fmt: skip
            ingest = worker.ingest_stats()
        finally:
            worker.stop()
    heads = [r.message for r in robot.of_type("request.face.headpose")]
    yaw = max(h["yaw"] for h in heads)
    pitch = max(h["pitch"] for h in heads)
    # The FIR filter smooths the peak a little; read as degrees/180 it would be 3x (~115).
    assert 35.0 <= yaw <= 40.5
    assert 12.0 <= pitch <= 15.5
    no_face = ingest["receivers"]["livelink"]["no_face"]
    assert no_face == sum(y is None for y in recording.yaw_deg)
    assert ingest["drops"] == {}
