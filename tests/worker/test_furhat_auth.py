"""The Furhat login and face set-up as a real robot answers them (the peer follows Furhat's
own client, PyPI ``furhat-realtime-api`` 0.1.3: only ``access: true`` is a login)."""

from __future__ import annotations

import queue
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import zmq
from click.testing import CliRunner

from chameleons.backend.wizard import health
from chameleons.cli.worker_command import worker
from chameleons.worker.drivers import ROBOT_STATE, DriverEvent, FurhatDriver
from chameleons.worker.drivers.furhat_check import run_check
from chameleons.worker.frames import N_BLENDSHAPES
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.worker.control_peer import ControlPeer
from tests.worker.furhat_peer import FurhatPeer


def _config(server: ControlPeer, robot_url: str) -> WorkerConfig:
    return WorkerConfig(booth="booth-a", driver="furhat", robot_url=robot_url,
                        livelink_port=None, facecapturex_port=None,
                        command_endpoint=server.command_endpoint,
                        telemetry_endpoint=server.telemetry_endpoint)  # fmt: skip


def _heartbeat(
    server: ControlPeer, wanted: Callable[[dict[str, Any]], bool], timeout: float
) -> dict[str, Any]:
    """The first heartbeat (of those not yet looked at) that ``wanted`` accepts."""
    seen = len(server.of_type("heartbeat"))

    def found() -> dict[str, Any] | None:
        beats = server.of_type("heartbeat")[seen:]
        return next((dict(b.body) for b in beats if wanted(b.body)), None)

    beat: dict[str, Any] = server.wait(found, timeout)
    return beat


def _driver(url: str, **options: object) -> tuple[FurhatDriver, queue.SimpleQueue[DriverEvent]]:
    events: queue.SimpleQueue[DriverEvent] = queue.SimpleQueue()
    driver = FurhatDriver(url, key="wrong", backoff_initial=0.05, auth_timeout=0.5,
                          **options)  # type: ignore[arg-type]  # fmt: skip
    driver.bind_events(events.put)
    return driver, events


def _state(events: queue.SimpleQueue[DriverEvent], wanted: str) -> DriverEvent:
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        event = events.get(timeout=10)
        if event.kind == ROBOT_STATE and event.body.get("state") == wanted:
            return event
    raise AssertionError(f"no robot state {wanted}")


def _stream_for_a_while(driver: FurhatDriver, peer: FurhatPeer) -> None:
    """What the renderer does every tick; then give the sender time to have sent it."""
    for _ in range(50):
        driver.send_face(np.zeros(N_BLENDSHAPES, dtype=np.float32))
        driver.send_head(1.0, 2.0, 3.0)
    mark = len(peer.received)
    deadline = time.monotonic() + 0.5
    while time.monotonic() < deadline and len(peer.received) == mark:
        time.sleep(0.02)


def test_a_refused_login_stops_the_driver_with_the_reason_and_sends_nothing() -> None:
    with FurhatPeer(access=False) as peer:
        driver, events = _driver(peer.url)
        driver.start()
        try:
            refused = _state(events, "auth_refused")
            _stream_for_a_while(driver, peer)
            stats = driver.stats()
            connections = peer.connections
        finally:
            driver.close()
    assert "refused" in refused.body["reason"]
    assert stats["problem"] == refused.body["reason"]
    assert not driver.connected
    kinds = {r.type for r in peer.received}
    assert kinds == {"request.auth"}  # no face config, no params, no head poses
    assert connections == 1  # and no retry on its own
    assert stats["faces_sent"] == stats["heads_sent"] == 0


def test_an_unanswered_login_is_retried_with_backoff_until_the_robot_answers() -> None:
    """A robot still booting answers no login: the driver tries again by itself (nobody
    presses retry), saying when, and logs in once the robot answers."""
    with FurhatPeer(access=None) as peer:
        driver, events = _driver(peer.url)
        driver.start()
        try:
            timeout = _state(events, "auth_timeout")
            peer.wait_for(lambda p: p.connections >= 3, timeout=15)  # twice more, unasked
            problem = driver.stats()["problem"]
            peer.access = True  # the robot has booted
            _state(events, "connected")
            peer.wait_for(lambda p: bool(p.of_type("request.face.config")))
        finally:
            driver.close()
    assert timeout.body["reason"] == "the robot did not answer the login within 0.5 s"
    assert timeout.body["retry_in"] > 0
    assert problem == timeout.body["reason"]
    assert driver.problem is None


def test_the_login_waits_as_long_as_the_vendors_client_and_a_worker_reports_the_retry(
    zmq_context: zmq.Context[zmq.Socket[bytes]], server: ControlPeer
) -> None:
    """Through a real worker: a robot that answers the login after 4 s is logged in (the
    vendor's client waits 5 s; this driver gave up after 3 s and stopped for good), and one
    that does not answer at all is shown on the heartbeat, and so on the wizard's health
    strip, with when it is tried again."""
    assert FurhatDriver("ws://robot:9000/v1/events").auth_timeout == 5.0
    slow = FurhatPeer(auth_delay=4.0)
    with slow, Worker(_config(server, slow.url), context=zmq_context):
        connected = _heartbeat(server, lambda b: b.get("robot_connected") is True, 30)
    assert connected["robot_problem"] is None
    assert not [m for m in server.of_type("robot_state") if m.body["state"] == "auth_timeout"]
    silent = FurhatPeer(access=None)
    with silent, Worker(_config(server, silent.url), context=zmq_context):
        waiting = _heartbeat(server, lambda b: b.get("robot_retry_in") is not None, 30)
        silent.access = True  # the robot has booted: the worker logs in by itself
        _heartbeat(server, lambda b: b.get("robot_connected") is True, 30)
    assert waiting["robot_state"] == "auth_timeout"
    assert waiting["robot_problem"] == "the robot did not answer the login within 5 s"
    robot = health.evaluate(waiting, 0.0)["robot"]
    assert robot.ok is False
    assert robot.value.startswith("login not answered: the robot did not answer the login "
                                  "within 5 s; retrying in ")  # fmt: skip


def test_only_access_true_is_a_login_even_with_a_reply_without_error() -> None:
    with FurhatPeer(access=True) as peer:
        peer.access = "yes"  # type: ignore[assignment]  # truthy, but not the documented true
        driver, events = _driver(peer.url)
        driver.start()
        try:
            _state(events, "auth_refused")
        finally:
            driver.close()


def test_a_refused_face_field_is_surfaced_and_does_not_take_the_face_with_it() -> None:
    with FurhatPeer(refuse_fields=frozenset({"head_sway"})) as peer:
        driver, events = _driver(peer.url, face_id="face-1", faces={"face-1": "Isabel"})
        driver.start()
        try:
            _state(events, "connected")
            deadline = time.monotonic() + 10
            while "head_sway" not in driver.stats()["refused"] and time.monotonic() < deadline:
                time.sleep(0.02)
            stats = driver.stats()
        finally:
            driver.close()
    assert "unknown field head_sway" in stats["refused"]["head_sway"]
    assert "blinking" not in stats["refused"]
    face = peer.of_type("request.face.config")[0].message
    assert face["face_id"] == "Isabel"
    assert "head_sway" not in face


def test_check_lists_the_face_mapping_against_the_robots_faces() -> None:
    with FurhatPeer(faces=("adult - Alex", "Isabel")) as peer:
        report = run_check(peer.url, "key", {"face-1": "Isabel", "face-2": "Marty"})
        auth = peer.of_type("request.auth")[0].message
    assert report.problem is None
    assert auth["key"] == "key"
    assert [(r.study_face, r.robot_face, r.on_robot) for r in report.rows] == [
        ("face-1", "Isabel", True), ("face-2", "Marty", False),
    ]  # fmt: skip
    assert not report.ok
    text = "\n".join(report.lines())
    assert "face-2 -> Marty: NOT ON THE ROBOT" in text
    assert "adult - Alex" in text


def test_worker_check_command_exits_1_on_a_refused_login_and_0_when_all_faces_exist() -> None:
    with FurhatPeer(access=False) as peer:
        refused = CliRunner().invoke(worker, ["--check", "--robot-url", peer.url])
    with FurhatPeer(faces=("Isabel", "Marty")) as peer:
        good = CliRunner().invoke(worker, ["--check", "--robot-url", peer.url,
                                           "--furhat-face", "face-1=Isabel"])  # fmt: skip
    assert refused.exit_code == 1, refused.output
    assert "refused the login" in refused.output
    assert good.exit_code == 0, good.output
    assert "face-1 -> Isabel: ok" in good.output
