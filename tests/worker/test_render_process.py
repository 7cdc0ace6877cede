"""The renderer in a process of its own (``chameleons worker --renderer-process``): it ticks
and reports through the worker's heartbeat over ``ipc://`` sockets, its death stops the
worker, and it does not outlive a worker killed with ``kill -9``."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import zmq

from chameleons.worker.runtime import Worker, WorkerConfig
from tests.worker.control_peer import ControlPeer

BOOTH = "booth-rp"
WAIT_S = 120.0  # a spawned child imports NumPy, SciPy and ZeroMQ first; a loaded CI is slow


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


def _config(peer: ControlPeer) -> WorkerConfig:
    return WorkerConfig(
        booth=BOOTH, driver="null", command_endpoint=peer.command_endpoint,
        telemetry_endpoint=peer.telemetry_endpoint, livelink_port=None, facecapturex_port=None,
        renderer_process=True, renderer_realtime=True, renderer_cpu=0,
    )  # fmt: skip


def _ticking(peer: ControlPeer) -> dict[str, Any] | None:
    beats = [m.body for m in peer.of_type("heartbeat") if m.body.get("tick_rate_hz")]
    return beats[-1] if beats else None


def test_the_renderer_process_ticks_and_reports_through_the_heartbeat(
    zmq_context: zmq.Context[zmq.Socket[bytes]], peer: ControlPeer
) -> None:
    with Worker(_config(peer), context=zmq_context) as worker:
        child = worker.renderer_process
        assert child is not None
        assert worker.renderer is None
        assert child.process.pid not in (None, os.getpid())
        beat = peer.wait(lambda: _ticking(peer), WAIT_S)
        assert beat["tick_rate_hz"] > 0
        assert beat["driver"] == "null"
        assert beat["jitter_ms"]["p50"] is not None
        endpoint = worker.endpoints.render
        assert endpoint.startswith("ipc://")
        assert Path(endpoint.removeprefix("ipc://")).exists()
    assert not child.process.is_alive()
    assert not Path(endpoint.removeprefix("ipc://")).exists()  # its folder is cleaned up


def test_a_dead_renderer_process_stops_the_worker(
    zmq_context: zmq.Context[zmq.Socket[bytes]], peer: ControlPeer
) -> None:
    with Worker(_config(peer), context=zmq_context) as worker:
        child = worker.renderer_process
        assert child is not None
        assert child.process.pid is not None
        os.kill(child.process.pid, signal.SIGKILL)
        assert worker.failed.wait(WAIT_S)
        assert worker.stop_event.is_set()


def _children(parent: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == parent:
                found.append(int(entry.name))
    return found


def _wait_until(condition: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + WAIT_S
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting until {what}"
        time.sleep(0.05)


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process table from /proc")
def test_the_renderer_process_dies_with_a_killed_worker(tmp_path: Path) -> None:
    command = [sys.executable, "-m", "chameleons", "worker", "--booth", BOOTH,
               "--driver", "null", "--livelink-port", "0", "--facecapturex-port", "0",
               "--control", "tcp://127.0.0.1:9", "--telemetry", "tcp://127.0.0.1:9",
               "--renderer-process"]  # fmt: skip
    env = {**os.environ, "CHAMELEONS_DATA_DIR": str(tmp_path)}
    worker = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              env=env, text=True)  # fmt: skip
    output = worker.stdout
    assert output is not None
    try:
        seen = []
        for line in output:  # warnings may come first; the start line means it ticks
            seen.append(line)
            if "worker booth-rp" in line:
                break
        assert "worker booth-rp" in seen[-1], "".join(seen)
        children = _children(worker.pid)
        assert children, "the worker started no child process"
    finally:
        worker.kill()
        worker.wait()
        output.close()
    _wait_until(lambda: not any(_alive(pid) for pid in children), "the worker's children end")


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"
