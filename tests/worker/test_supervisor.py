"""The embedded setup: the server's bridge supervises a real ``chameleons worker`` process.
Killing the worker mid-stream: it is restarted, gets its behaviour, face and recording
back, and the robot (the Furhat peer) copies the participant again."""

from __future__ import annotations

import asyncio
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from chameleons.backend.bridge import Bridge, WorkerSupervisor
from chameleons.worker.recording import RecordingError, read_recording
from tests.worker.furhat_peer import FurhatPeer
from tests.worker.phone import Pose, SteppingPhone

BOOTH = "sup"
PART2_AGENT = "interaction-5-part2-agent.parquet"  # the robot's recording after the restart
START_TIMEOUT = 40.0  # a fresh Python process importing numpy/scipy on a busy machine


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


async def _until(condition: Callable[[], object], timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("condition not met in time")
        await asyncio.sleep(0.05)


def _has_frames(path: Path) -> bool:
    """The recording (its journal, while it is being written) holds more than ten frames."""
    try:
        return len(read_recording(path)) > 10
    except (FileNotFoundError, RecordingError):  # no file yet, or no chunk flushed yet
        return False


def _copying_since(robot: FurhatPeer, since: float) -> Callable[[], bool]:
    """The robot turned towards the participant's alternating yaw after ``since``."""
    return lambda: any(r.time > since and r.message["yaw"] > 10
                       for r in robot.of_type("request.face.headpose"))  # fmt: skip


@pytest.mark.slow
def test_a_killed_worker_is_restarted_with_its_state(tmp_path: Path) -> None:
    port = _free_udp_port()
    poses = [Pose(20.0, 0.0, 0.5), Pose(-20.0, 0.0, 0.0)] * 60
    times = [0.5 * i for i in range(len(poses))]
    env = {**os.environ, "CHAMELEONS_DATA_DIR": str(tmp_path), "CHAMELEONS_MIRROR": "false"}
    recordings = tmp_path / "rec"

    async def scenario(robot: FurhatPeer) -> None:
        async with Bridge("tcp://127.0.0.1:*", "tcp://127.0.0.1:*") as bridge:
            args = ["--driver", "furhat", "--robot-url", robot.url, "--livelink-port", str(port),
                    "--facecapturex-port", "0", "--behaviour", "still"]  # fmt: skip
            supervisor = WorkerSupervisor(bridge, BOOTH, args, env=env, backoff=0.1)
            await supervisor.start()
            try:
                with bridge.subscribe(BOOTH, ("worker",)) as connection, \
                        SteppingPhone(port, poses, times):  # fmt: skip
                    await _until(lambda: BOOTH in bridge.workers(), START_TIMEOUT)
                    for kind, body in (
                        ("set_face", {"face_id": "adult-02"}),
                        ("set_behaviour", {"name": "copy", "params": {"delay": 0.3}}),
                        ("start_recording", {"interaction_id": 5, "directory": str(recordings)}),
                    ):
                        assert (await bridge.send_command(BOOTH, kind, body, timeout=5)).ok
                    # Copying, with the recording past its first chunk on disk (on a busy
                    # machine frames arrive late, so wait for the chunk, not for a time).
                    await _until(_copying_since(robot, time.monotonic() + 0.6), 10)
                    participant = recordings / "interaction-5-participant.parquet"
                    await _until(lambda: _has_frames(participant), 20)

                    assert supervisor.process is not None
                    os.kill(supervisor.process.pid, signal.SIGKILL)
                    killed = time.monotonic()
                    async for message in connection:
                        if message.type == "worker_restarted":
                            break
                    await _until(lambda: robot.connections == 2, START_TIMEOUT)
                    await _until(_copying_since(robot, killed), 15)  # copy was re-sent
                    await _until(lambda: bridge.workers()[BOOTH].replays == 1, 10)
                    # The second part has frames once the renderer has ticked after the
                    # replay and the recorder has journaled them (at load the first ticks
                    # come late, and robot poses say nothing of the recorder): wait for the
                    # part's own journal, not for time or for the robot.
                    await _until(lambda: _has_frames(recordings / PART2_AGENT), 20)
                    stopped = await bridge.send_command(BOOTH, "stop_recording", {}, timeout=5)
            finally:
                await supervisor.stop()
        assert supervisor.starts == 2
        assert supervisor.exit_codes[0] == -signal.SIGKILL
        assert stopped.ok
        files = stopped.result["files"]
        assert files["agent"].endswith(PART2_AGENT)
        assert len(read_recording(files["agent"])) > 10
        # What the killed worker had recorded was recovered from its journal.
        assert _has_frames(recordings / "interaction-5-participant.parquet")

    with FurhatPeer() as robot:
        asyncio.run(scenario(robot))
    every = [r.message for r in robot.of_type("request.face.config")]
    configs = [c for c in every if "face_id" in c]
    assert configs[-1]["face_id"] == "adult-02"  # the face came back after the restart
    assert all(c["microexpressions"] is False for c in configs)
    # The robot's idle motion went off again after the restart (each field on its own).
    assert sum(c.get("blinking") is False for c in every) == 2
    assert sum(c.get("head_sway") is False for c in every) == 2


# A server that starts a supervisor, says its worker's pid once the worker said hello, and
# waits: the test SIGKILLs it.
SERVER_SCRIPT = """
import asyncio, sys, time
from chameleons.backend.bridge import Bridge, WorkerSupervisor

async def main() -> None:
    async with Bridge("tcp://127.0.0.1:*", "tcp://127.0.0.1:*") as bridge:
        args = ["--driver", "null", "--livelink-port", "0", "--facecapturex-port", "0"]
        supervisor = WorkerSupervisor(bridge, "orphan", args)
        await supervisor.start()
        deadline = time.monotonic() + float(sys.argv[1])
        while "orphan" not in bridge.workers() and time.monotonic() < deadline:
            await asyncio.sleep(0.05)
        print("worker pid", supervisor.process.pid if supervisor.process else 0, flush=True)
        await asyncio.Event().wait()

asyncio.run(main())
"""


def _alive(pid: int) -> bool:
    """Running (a zombie nobody reaped yet counts as gone)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state != "Z"


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_a_server_killed_hard_leaves_no_worker_behind(tmp_path: Path) -> None:
    env = {**os.environ, "CHAMELEONS_DATA_DIR": str(tmp_path)}
    server = subprocess.Popen([sys.executable, "-c", SERVER_SCRIPT, str(START_TIMEOUT)], env=env,
                              stdout=subprocess.PIPE, text=True)  # fmt: skip
    worker = 0
    try:
        assert server.stdout is not None
        for line in server.stdout:  # the worker shares the server's stdout
            if line.startswith("worker pid "):
                worker = int(line.split()[-1])
                break
        assert worker, "the server never reported its worker"
        assert _alive(worker)
        assert os.getsid(worker) == worker  # its own session: a terminal's Ctrl-C misses it
        server.kill()
        server.wait()
        # The worker stops its stages and exits on the SIGTERM; at load that took over 10 s
        # once here (a hang would outlast any deadline and still fail).
        deadline = time.monotonic() + 30
        while _alive(worker):
            if time.monotonic() >= deadline:
                _dump_stacks(worker)
                raise AssertionError(f"worker {worker} outlived its killed server (its "
                                     "threads' stacks are in the captured stderr)")  # fmt: skip
            time.sleep(0.02)  # polling the process table, bounded by the deadline
    finally:
        server.kill()
        server.wait()
        if worker and _alive(worker):
            os.kill(worker, signal.SIGKILL)
        if server.stdout is not None:
            server.stdout.close()


def _dump_stacks(pid: int) -> None:
    """The worker prints its threads' stacks on SIGUSR1 (to the stderr it shares with the
    test); faulthandler writes them from the signal handler, at once."""
    os.kill(pid, signal.SIGUSR1)
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and _alive(pid):
        time.sleep(0.1)  # a failing test's pause for the dump, not a condition
