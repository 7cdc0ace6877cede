"""A prompt the Furhat could not play, through a real worker: the robot's
``response.speak.end`` with ``failed: true`` (Furhat's documented speech end carries
``aborted`` and ``failed``; docs/furhat.md) ends the play ``failed`` with the reason, never
``played``. The usual cause is an audio URL the robot cannot reach: the server's address
left on 127.0.0.1 (``CHAMELEONS_PUBLIC_URL`` unset), which the reason names."""

from __future__ import annotations

import pytest
import zmq

from chameleons.worker.envelope import Message
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.worker.control_peer import ControlPeer
from tests.worker.furhat_peer import FurhatPeer

BOOTH = "booth-f"
LOOPBACK_URL = "http://127.0.0.1:8000/media/prompts/m1/intro.wav?key=k"
LAN_URL = "http://192.168.1.20:8000/media/prompts/m1/intro.wav?key=k"


def _config(server: ControlPeer, robot_url: str) -> WorkerConfig:
    return WorkerConfig(booth=BOOTH, driver="furhat", robot_url=robot_url, livelink_port=None,
                        facecapturex_port=None, command_endpoint=server.command_endpoint,
                        telemetry_endpoint=server.telemetry_endpoint)  # fmt: skip


def _connected(server: ControlPeer) -> None:
    server.wait(lambda: any(m.body.get("robot_connected")
                            for m in server.of_type("heartbeat")), 15)  # fmt: skip


def _play(server: ControlPeer, prompt: str, url: str) -> Message:
    """Play a prompt; its speech end."""
    ack = server.command(BOOTH, "play_prompt", {"prompt_id": prompt, "play_id": f"play-{prompt}",
                                                "audio_url": url})  # fmt: skip
    assert ack.ok, ack
    end: Message = server.wait(lambda: next((m for m in server.of_type("speech_end")
                                             if m.body.get("prompt_id") == prompt), None),
                               15)  # fmt: skip
    return end


@pytest.mark.parametrize("started", [True, False], ids=["after_its_start", "without_a_start"])
def test_a_failed_speech_end_is_failed_with_the_url_and_the_loopback_hint(
    zmq_context: zmq.Context[zmq.Socket[bytes]], server: ControlPeer, started: bool
) -> None:
    robot = FurhatPeer(unplayable=lambda url: "127.0.0.1" in url, start_before_failure=started)
    with robot, Worker(_config(server, robot.url), context=zmq_context):
        _connected(server)
        failed = _play(server, "p1", LOOPBACK_URL)
        played = _play(server, "p2", LAN_URL)  # a URL the robot reaches plays as before
        (wire,) = [m for m in robot.sent_of_type("response.speak.end") if m["failed"]]
    # The robot's end as Furhat documents it, answering the request by its id.
    assert set(wire) == {"type", "request_id", "text", "aborted", "failed"}
    assert (wire["failed"], wire["aborted"]) == (True, False)
    assert failed.body["outcome"] == "failed"
    assert failed.body["play_id"] == "play-p1"
    error = failed.body["error"]
    assert error.startswith(f"the robot could not play the audio at {LOOPBACK_URL}")
    assert "127.0.0.1 is the server's own loopback address" in error
    assert "CHAMELEONS_PUBLIC_URL" in error
    starts = [m for m in server.of_type("speech_start") if m.body.get("prompt_id") == "p1"]
    assert len(starts) == (1 if started else 0)
    assert played.body["outcome"] == "played"
    assert "error" not in played.body
    assert robot.spoken == [LAN_URL]
    assert robot.failed == ([LOOPBACK_URL] if started else [])


def test_a_failed_url_the_robot_could_reach_otherwise_names_the_url_without_the_hint(
    zmq_context: zmq.Context[zmq.Socket[bytes]], server: ControlPeer
) -> None:
    robot = FurhatPeer(unplayable=lambda url: "missing" in url)
    with robot, Worker(_config(server, robot.url), context=zmq_context):
        _connected(server)
        url = "http://192.168.1.20:8000/media/prompts/m1/missing.wav"
        failed = _play(server, "p1", url)
    assert failed.body["outcome"] == "failed"
    assert failed.body["error"] == f"the robot could not play the audio at {url}"
