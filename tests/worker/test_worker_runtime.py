"""The worker process in-process: real stages on inproc sockets, a real control peer."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
import zmq

from chameleons.worker.control import make_command
from chameleons.worker.envelope import serialize
from chameleons.worker.recording import read_recording
from chameleons.worker.runtime import Worker, WorkerConfig
from chameleons.worker.stage import Endpoints
from tests.worker.control_peer import ControlPeer

BOOTH = "booth-t"


@pytest.fixture
def zmq_context() -> Iterator[zmq.Context[zmq.Socket[bytes]]]:
    ctx: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    yield ctx
    ctx.term()


@pytest.fixture
def peer(zmq_context: zmq.Context[zmq.Socket[bytes]]) -> Iterator[ControlPeer]:
    server = ControlPeer(zmq_context)
    yield server
    server.close()


def _config(peer: ControlPeer, **overrides: object) -> WorkerConfig:
    values: dict[str, object] = {
        "booth": BOOTH, "driver": "null", "command_endpoint": peer.command_endpoint,
        "telemetry_endpoint": peer.telemetry_endpoint, "livelink_port": 0,
        "facecapturex_port": None, "capture_host": "127.0.0.1", "mirror": False,
    }  # fmt: skip
    values.update(overrides)
    return WorkerConfig(**values)  # type: ignore[arg-type]


@pytest.fixture
def worker(zmq_context: zmq.Context[zmq.Socket[bytes]], peer: ControlPeer) -> Iterator[Worker]:
    with Worker(_config(peer), context=zmq_context) as running:
        yield running


def test_hello_then_commands_are_acked_with_their_seq(worker: Worker, peer: ControlPeer) -> None:
    ack = peer.command(BOOTH, "set_behaviour", {"name": "copy", "params": {"delay": 0.5}})
    assert ack.ok
    assert ack.result["behaviour"] == "copy"
    hello = peer.hellos[0].body
    assert hello["instance"] == worker.hub.instance
    assert hello["driver"] == "null"


def test_unknown_and_malformed_commands_get_errors_and_the_loop_goes_on(
    worker: Worker, peer: ControlPeer
) -> None:
    assert peer.command(BOOTH, "status").ok
    peer.send_raw(BOOTH, [b"garbage"])
    assert peer.ack(-1).error == "malformed"
    peer.send_raw(BOOTH, serialize(make_command("fly", {}, seq=9)))
    assert peer.ack(9).error == "unknown_command"
    bad = peer.command(BOOTH, "set_behaviour", {"name": "dance"})
    assert (bad.ok, bad.error) == (False, "bad_behaviour")
    assert "unknown behaviour 'dance'" in bad.detail
    assert peer.command(BOOTH, "set_behaviour", {"name": "still"}).ok
    status = peer.command(BOOTH, "status").result
    assert status["drops"]["hub"] == {"command_malformed": 1, "command_unknown_command": 1}


def test_heartbeat_carries_the_pipeline_health(worker: Worker, peer: ControlPeer) -> None:
    beat = peer.wait(lambda: next((m for m in peer.of_type("heartbeat")
                                   if m.body["tick_rate_hz"]), None), timeout=10)  # fmt: skip
    body = beat.body
    assert beat.topic == f"telemetry.{BOOTH}"
    assert body["tick_rate_hz"] > 50
    assert set(body["jitter_ms"]) == {"p50", "p99", "max"}
    assert body["robot_connected"] is True
    assert body["speaking"] is False
    for key in ("missed_ticks", "input_fps", "capture_to_send_ms", "drops", "behaviour"):
        assert key in body


def test_prompt_speech_events_follow_the_lipsync_curve(
    worker: Worker, peer: ControlPeer, tmp_path: Path
) -> None:
    curve = tmp_path / "p1.csv"
    curve.write_text("time,jawOpen\n0,0\n0.15,0.9\n0.3,0\n")
    ack = peer.command(BOOTH, "play_prompt", {"prompt_id": "p1", "audio_url": "http://x/p1.wav",
                                              "lipsync_path": str(curve)})  # fmt: skip
    assert ack.ok
    assert ack.result["lipsync_seconds"] == pytest.approx(0.3)
    end = peer.wait(lambda: next(iter(peer.of_type("speech_end")), None))
    start = peer.of_type("speech_start")[0]
    assert start.topic == end.topic == f"event.{BOOTH}"
    assert start.body["prompt_id"] == end.body["prompt_id"] == "p1"
    # The null driver never reports the end of the audio: it ends with the curves.
    assert end.body["worker_time"] - start.body["worker_time"] == pytest.approx(0.3, abs=0.02)
    missing = str(tmp_path / "none.csv")
    bad = peer.command(BOOTH, "play_prompt",
                       {"prompt_id": "p2", "audio_url": "x", "lipsync_path": missing})  # fmt: skip
    assert (bad.ok, bad.error) == (False, "bad_lipsync")


def test_recording_writes_participant_and_agent_streams(
    worker: Worker, peer: ControlPeer, tmp_path: Path
) -> None:
    ack = peer.command(BOOTH, "start_recording", {"interaction_id": 7, "directory": str(tmp_path)})
    assert ack.ok
    renderer = worker.renderer
    assert renderer is not None
    peer.wait(lambda: renderer.loop.stats.count > 40)  # some agent frames went out
    stopped = peer.command(BOOTH, "stop_recording", {"interaction_id": 7})
    assert stopped.ok
    files = stopped.result["files"]
    assert Path(files["agent"]).name == "interaction-7-agent.parquet"
    assert len(read_recording(files["agent"])) >= 20
    assert Path(files["participant"]).exists()
    event = peer.wait(lambda: next(iter(peer.of_type("recording_stopped")), None))
    assert event.body["files"] == files
    again = peer.command(BOOTH, "start_recording", {"interaction_id": 7,
                                                    "directory": str(tmp_path)})  # fmt: skip
    assert again.result["files"]["agent"].endswith("interaction-7-part2-agent.parquet")


def test_default_copy_delay_is_4_000_seconds(zmq_context: zmq.Context[zmq.Socket[bytes]],
                                              peer: ControlPeer) -> None:  # fmt: skip
    config = _config(peer, behaviour="copy")
    assert config.initial_params() == {"delay": 4.0}
    with Worker(config, context=zmq_context) as running:
        status = peer.command(BOOTH, "status").result
        assert running.behaviour.router.current_name == "copy"
    assert status["booth"] == BOOTH


def test_the_same_stages_run_over_ipc_sockets(
    zmq_context: zmq.Context[zmq.Socket[bytes]], peer: ControlPeer
) -> None:
    """Only the endpoints change between threads (inproc) and processes (ipc/tcp)."""
    directory = Path(tempfile.mkdtemp(prefix="chm-", dir="/tmp"))  # ipc paths must be short
    try:
        config = _config(peer, endpoints=Endpoints.ipc(BOOTH, directory))
        with Worker(config, context=zmq_context) as running:
            assert peer.command(
                BOOTH, "set_behaviour", {"name": "natural", "params": {"seed": 1}}
            ).ok
            renderer = running.renderer
            assert renderer is not None
            peer.wait(lambda: renderer.core is not None and renderer.core.keyframes_in > 20)
            assert sorted(p.name for p in directory.iterdir())[0].endswith(".sock")
    finally:
        shutil.rmtree(directory, ignore_errors=True)


@pytest.mark.parametrize("attempt", range(3))
def test_what_the_stages_say_on_stopping_reaches_the_server(
    zmq_context: zmq.Context[zmq.Socket[bytes]], peer: ControlPeer, attempt: int
) -> None:
    """The hub stops after the other stages, so their last words (the robot closed, a
    recording stopped) are carried out; before, the hub could leave first and drop them."""
    worker = Worker(_config(peer), context=zmq_context).start()
    try:
        peer.wait(lambda: peer.of_type("heartbeat"), timeout=10)  # the hub is up
    finally:
        worker.stop()
    closed = peer.wait(lambda: [m for m in peer.of_type("robot_state")
                                if m.body.get("state") == "closed"], timeout=10)  # fmt: skip
    assert closed[0].topic == f"event.{BOOTH}"


def test_set_face_takes_the_display_renderer_and_refuses_a_wrong_one(
    worker: Worker, peer: ControlPeer
) -> None:
    ack = peer.command(BOOTH, "set_face", {"face_id": "face-2", "renderer": "3d"})
    assert ack.ok
    assert ack.result == {"face_id": "face-2", "renderer": "3d"}
    bad = peer.command(BOOTH, "set_face", {"face_id": "face-2", "renderer": "4d"})
    assert (bad.ok, bad.error) == (False, "bad_renderer")
