"""Typed speech through a whole worker to a Furhat: the wizard's sentence goes to the robot's
own TTS (``request.speak.text``, after ``request.voice.config`` when the study names a
voice), its speech start and end come back like a prompt's, and a robot without TTS refuses
the text. The robot is the project's Furhat peer, modelled on Furhat's own client."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import zmq

from chameleons.worker.envelope import Message
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.worker.control_peer import ControlPeer
from tests.worker.furhat_peer import FurhatPeer

BOOTH = "booth-t"
SENTENCE = "The road is about seventy miles away."


@pytest.fixture
def zmq_context() -> Iterator[zmq.Context[zmq.Socket[bytes]]]:
    ctx: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    yield ctx
    ctx.term()


@pytest.fixture
def server(zmq_context: zmq.Context[zmq.Socket[bytes]]) -> Iterator[ControlPeer]:
    peer = ControlPeer(zmq_context)
    yield peer
    peer.close()


def _config(server: ControlPeer, driver: str, robot_url: str = "") -> WorkerConfig:
    return WorkerConfig(booth=BOOTH, driver=driver, robot_url=robot_url or "ws://127.0.0.1:9",
                        command_endpoint=server.command_endpoint,
                        telemetry_endpoint=server.telemetry_endpoint, livelink_port=0,
                        facecapturex_port=None, capture_host="127.0.0.1")  # fmt: skip


def _speech(server: ControlPeer, kind: str, prompt: str, timeout: float = 15.0) -> Message:
    found: Message = server.wait(lambda: next((m for m in server.of_type(kind)
                                               if m.body.get("prompt_id") == prompt), None),
                                 timeout)  # fmt: skip
    return found


def _connected(server: ControlPeer) -> None:
    """Wait for a heartbeat saying the driver is logged in to the robot (a heartbeat comes
    every second; a one-off state event could go out before the peer listens)."""
    server.wait(lambda: any(m.body.get("robot_connected")
                            for m in server.of_type("heartbeat")), 15)  # fmt: skip


def _say(server: ControlPeer, prompt: str, voice: str | None) -> dict[str, object]:
    ack = server.command(BOOTH, "play_prompt", {"prompt_id": prompt, "audio_url": "",
                                                "text": SENTENCE, "voice": voice})  # fmt: skip
    assert ack.ok, ack
    return ack.result


def test_a_typed_sentence_is_said_by_the_furhats_own_tts_in_the_actors_voice(
    zmq_context: zmq.Context[zmq.Socket[bytes]], server: ControlPeer
) -> None:
    robot = FurhatPeer(speech_seconds=0.4)
    with robot, Worker(_config(server, "furhat", robot.url), context=zmq_context):
        _connected(server)
        result = _say(server, "typed-1", "Joanna-Neural")
        start = _speech(server, "speech_start", "typed-1")
        end = _speech(server, "speech_end", "typed-1")
        _say(server, "typed-2", "Joanna-Neural")  # the voice is set already
        _speech(server, "speech_end", "typed-2")
        configs = [r.message for r in robot.of_type("request.voice.config")]
        spoken = [r.message for r in robot.of_type("request.speak.text")]
        order = [r.type for r in robot.received
                     if r.type in ("request.voice.config", "request.speak.text")]  # fmt: skip
    assert result["robot_tts"] is True
    assert configs == [{"type": "request.voice.config", "name": "Joanna-Neural"}]
    assert order == ["request.voice.config", "request.speak.text", "request.speak.text"]
    assert [m["text"] for m in spoken] == [SENTENCE, SENTENCE]
    assert spoken[0]["abort"] is False
    assert isinstance(spoken[0]["request_id"], str)
    assert robot.said == [(SENTENCE, "Joanna-Neural"), (SENTENCE, "Joanna-Neural")]
    assert end.body["outcome"] == "played"
    assert end.body["worker_time"] - start.body["worker_time"] >= 0.3  # the robot's own end
    assert not robot.of_type("request.speak.audio")  # no WAV on the Furhat path


def test_without_a_study_voice_the_robot_keeps_its_own_and_a_prompt_under_way_is_stopped(
    zmq_context: zmq.Context[zmq.Socket[bytes]], server: ControlPeer
) -> None:
    # The prompt speaks for a minute (still speaking however busy the machine when the text
    # comes: 1.5 s ran out at load 12); the text is short.
    robot = FurhatPeer(speech_seconds=60.0)
    with robot, Worker(_config(server, "furhat", robot.url), context=zmq_context):
        _connected(server)
        audio = {"prompt_id": "p1", "audio_url": "http://s/p1.wav"}
        played = server.command(BOOTH, "play_prompt", audio)
        assert played.ok
        _speech(server, "speech_start", "p1")
        robot.speech_seconds = 0.3  # the next utterance's length
        _say(server, "typed-1", None)
        first = _speech(server, "speech_end", "p1")
        end = _speech(server, "speech_end", "typed-1")
        requests = [r.type for r in robot.received if r.type.startswith("request.speak")]
        typed = robot.of_type("request.speak.text")[0].message
    assert not robot.of_type("request.voice.config")
    assert robot.said == [(SENTENCE, robot.voices[0])]  # the robot's current voice
    # The prompt under way is stopped before the text (the robot would queue it otherwise).
    # The render stage stops it (one stop), and the text aborts whatever is left, whether
    # or not the robot's end of the prompt has come back by then (a busy machine: both).
    assert requests == ["request.speak.audio", "request.speak.stop", "request.speak.text"]
    assert typed["abort"] is True
    assert first.body["outcome"] == "interrupted"
    assert end.body["outcome"] == "played"


def test_a_robot_without_tts_refuses_the_text(
    zmq_context: zmq.Context[zmq.Socket[bytes]], server: ControlPeer
) -> None:
    with Worker(_config(server, "null"), context=zmq_context):
        ack = server.command(BOOTH, "play_prompt", {"prompt_id": "typed-1", "audio_url": "",
                                                    "text": SENTENCE})  # fmt: skip
    assert (ack.ok, ack.error) == (False, "no_tts")
    assert "no text-to-speech" in ack.detail
