"""Through a real worker, every play of a prompt gets exactly one speech end, matched by its
play id, when a new prompt replaces it while it speaks (issue 28):

- the virtual robot: the worker ends the replaced play itself (``interrupted``) and the
  robot display page then reports that play's end too (it finishes every play it had,
  ``interrupted`` included: ``display.js``); the page's end must not go out a second time;
- a Furhat (the project's peer, modelled on Furhat's own Realtime API client): the robot's
  ``response.speak.start`` of the first play and the wizard's second prompt arrive at the
  worker together (the second press comes right as the robot starts the first); the
  first play must still end once, neither twice nor never.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable

import zmq

from chameleons.worker.envelope import Message
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.worker.control_peer import ControlPeer
from tests.worker.furhat_peer import FurhatPeer

BOOTH = "booth-e"
ROUNDS = 6  # the Furhat race is a matter of ticks: several rounds, each must hold


def _config(server: ControlPeer, driver: str, robot_url: str = "ws://127.0.0.1:9") -> WorkerConfig:
    return WorkerConfig(booth=BOOTH, driver=driver, robot_url=robot_url, livelink_port=None,
                        facecapturex_port=None, command_endpoint=server.command_endpoint,
                        telemetry_endpoint=server.telemetry_endpoint)  # fmt: skip


def _play(server: ControlPeer, prompt: str, play_id: str) -> None:
    ack = server.command(BOOTH, "play_prompt", {"prompt_id": prompt, "play_id": play_id,
                                                "audio_url": f"http://s/{prompt}.wav"})  # fmt: skip
    assert ack.ok, ack


def _of_play(server: ControlPeer, kind: str, play_id: str) -> list[Message]:
    return [m for m in server.of_type(kind) if m.body.get("play_id") == play_id]


def _ended(server: ControlPeer, play_id: str) -> Message:
    found: Message = server.wait(lambda: next(iter(_of_play(server, "speech_end", play_id)),
                                              None), 15)  # fmt: skip
    return found


def _started_after(starts: int) -> Callable[[FurhatPeer], bool]:
    """The robot has sent a speech start beyond the first ``starts``."""
    return lambda robot: len(robot.sent_of_type("response.speak.start")) > starts


def _ends(server: ControlPeer) -> Counter[str]:
    return Counter(str(m.body.get("play_id")) for m in server.of_type("speech_end"))


def test_the_display_pages_end_of_a_replaced_play_is_not_a_second_end(
    zmq_context: zmq.Context[zmq.Socket[bytes]], server: ControlPeer
) -> None:
    with Worker(_config(server, "virtual"), context=zmq_context):
        _play(server, "p1", "play-1")
        server.wait(lambda: server.of_type("play_audio"), 10)
        # The page: the first play starts ...
        assert server.command(BOOTH, "speech_event", {"event": "start", "prompt_id": "p1",
                                                      "play_id": "play-1"}).ok  # fmt: skip
        server.wait(lambda: _of_play(server, "speech_start", "play-1"), 10)
        _play(server, "p2", "play-2")  # ... the wizard plays the next prompt over it ...
        first = _ended(server, "play-1")
        # ... and the page, given the second play, finishes the first one: interrupted.
        assert server.command(BOOTH, "speech_event", {"event": "end", "prompt_id": "p1",
                                                      "play_id": "play-1"}).ok  # fmt: skip
        for event in ("start", "end"):
            assert server.command(BOOTH, "speech_event", {"event": event, "prompt_id": "p2",
                                                          "play_id": "play-2"}).ok  # fmt: skip
        _ended(server, "play-2")
        # A heartbeat after the last end: everything the worker sent before it is here.
        count = len(server.of_type("heartbeat"))
        server.wait(lambda: len(server.of_type("heartbeat")) > count, 10)
    assert first.body["outcome"] == "interrupted"
    assert _ends(server) == {"play-1": 1, "play-2": 1}


def test_a_furhat_play_replaced_as_the_robot_starts_it_ends_exactly_once(
    zmq_context: zmq.Context[zmq.Socket[bytes]], server: ControlPeer
) -> None:
    robot = FurhatPeer(start_latency=0.05, speech_seconds=0.4)
    with robot, Worker(_config(server, "furhat", robot.url), context=zmq_context):
        server.wait(lambda: any(m.body.get("robot_connected")
                                for m in server.of_type("heartbeat")), 15)  # fmt: skip
        for n in range(ROUNDS):
            first, second = f"play-{n}a", f"play-{n}b"
            started = _started_after(len(robot.sent_of_type("response.speak.start")))
            _play(server, f"p{n}a", first)
            robot.wait_for(started)  # the second press comes as the robot starts the first
            _play(server, f"p{n}b", second)
            _ended(server, second)
        count = len(server.of_type("heartbeat"))
        server.wait(lambda: len(server.of_type("heartbeat")) > count, 10)
    ends = _ends(server)
    plays = [f"play-{n}{x}" for n in range(ROUNDS) for x in "ab"]
    assert {play: ends[play] for play in plays} == dict.fromkeys(plays, 1)
    for n in range(ROUNDS):
        (end,) = _of_play(server, "speech_end", f"play-{n}a")
        assert end.body["outcome"] in ("interrupted", "skipped"), end.body
        for start in _of_play(server, "speech_start", f"play-{n}a"):
            assert start.body["worker_time"] <= end.body["worker_time"]
