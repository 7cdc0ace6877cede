"""A worker's one-off ``robot_state`` event can be lost: a ZeroMQ PUB drops what it sends
before the server's subscription has reached it, and a worker connects to its robot within
moments of starting (seen in the full suite at load: no ``robot.connected`` in 10 s). The
heartbeat repeats the robot's state every second, so the booth flow logs the connection
from it. The peer here is a bare PUB socket that speaks the worker's envelope and sends
only heartbeats, as a worker whose event was lost."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
import zmq

from chameleons.backend.bridge import Bridge
from chameleons.worker.control import telemetry_topic
from chameleons.worker.envelope import Message
from chameleons.worker.stage import send_message
from tests.backend.booth.conftest import BOOTH, new_session, timeline, until
from tests.support.bots import StaffApi, WizardBot


@contextmanager
def heartbeat_only_worker(bridge: Bridge) -> Iterator[zmq.Socket[bytes]]:
    context = zmq.Context()
    uplink = context.socket(zmq.PUB)
    uplink.setsockopt(zmq.LINGER, 0)
    uplink.connect(bridge.telemetry_endpoint)
    try:
        yield uplink
    finally:
        uplink.close()
        context.term()


def _beat(uplink: zmq.Socket[bytes], seq: int, robot_state: str) -> None:
    body = {"robot_state": robot_state, "robot_connected": robot_state == "connected"}
    message = Message(telemetry_topic(BOOTH), "heartbeat", seq, "hub", time.monotonic(), body)
    send_message(uplink, message)


def _robot_events(wizard: WizardBot) -> list[str]:
    return [e["kind"] for e in timeline(wizard) if e["kind"].startswith("robot.")]


@pytest.mark.usefixtures("flow")
def test_a_robot_seen_connected_only_in_heartbeats_is_logged_once(
    pi: StaffApi, study_id: int, bridge: Bridge
) -> None:
    wizard, _ = new_session(pi, study_id)
    wizard.start()
    beats = 0
    with heartbeat_only_worker(bridge) as uplink:

        def beat_until_logged() -> bool:
            nonlocal beats
            beats += 1
            _beat(uplink, beats, "connected")
            time.sleep(0.05)  # the 1 Hz heartbeat, faster: the first ones may be dropped
            return "robot.connected" in _robot_events(wizard)

        until(beat_until_logged, 30, what="robot.connected from the heartbeat")
        for extra in range(5):  # later heartbeats say the same: no second event
            _beat(uplink, beats + 1 + extra, "connected")
        seen_before = dict(bridge.dropped)
        _beat(uplink, beats + 10, "auth_refused")  # a change is still logged
        until(lambda: "robot.auth_refused" in _robot_events(wizard), 30, what="the refusal")
    assert _robot_events(wizard).count("robot.connected") == 1
    assert bridge.dropped == seen_before  # well-formed beats: none counted as bad
