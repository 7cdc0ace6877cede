"""A real ``chameleons worker`` process and its signals: ``kill -USR1`` prints every
thread's stack to stderr (where a stuck worker waits) and it goes on; SIGTERM and Ctrl-C
stop it cleanly and it ends with the conventional 143 / 130."""

from __future__ import annotations

import os
import queue
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path
from typing import IO

import pytest

from chameleons.backend.bridge.supervisor import WORKER_MODULE

DEADLINE_S = 60.0  # a fresh process importing numpy on a busy machine, with room


def _free_tcp_endpoint() -> str:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return f"tcp://127.0.0.1:{sock.getsockname()[1]}"


class Lines:
    """A stream's lines as they come (a thread reads it: no read blocks the test)."""

    def __init__(self, stream: IO[str]) -> None:
        self.stream = stream
        self.queue: queue.SimpleQueue[str] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._pump, daemon=True)
        self._thread.start()

    def _pump(self) -> None:
        for line in self.stream:
            self.queue.put(line)

    def until(self, wanted: str) -> list[str]:
        seen: list[str] = []
        while True:
            try:
                line = self.queue.get(timeout=DEADLINE_S)
            except queue.Empty:
                raise AssertionError(f"no line with {wanted!r} in time; saw {seen}") from None
            seen.append(line)
            if wanted in line:
                return seen

    def close(self) -> None:
        """Once the process has ended: its end of the pipe is closed, so the reader ends."""
        self._thread.join(DEADLINE_S)
        self.stream.close()


@pytest.mark.skipif(not hasattr(signal, "SIGUSR1"), reason="no SIGUSR1 here")
def test_usr1_prints_every_threads_stack_and_the_worker_goes_on(tmp_path: Path) -> None:
    command = [sys.executable, "-m", WORKER_MODULE, "--booth", "signals", "--driver", "null",
               "--control", _free_tcp_endpoint(), "--telemetry", _free_tcp_endpoint(),
               "--livelink-port", "0", "--facecapturex-port", "0"]  # fmt: skip
    env = {**os.environ, "CHAMELEONS_DATA_DIR": str(tmp_path)}
    worker = subprocess.Popen(command, env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True)  # fmt: skip
    assert worker.stdout is not None
    assert worker.stderr is not None
    out, err = Lines(worker.stdout), Lines(worker.stderr)
    try:
        out.until("Ctrl-C stops")  # started: the signal handlers are in place
        worker.send_signal(signal.SIGUSR1)
        stacks = "".join(err.until("run_worker"))  # the main thread waits in run_worker
        assert "Thread 0x" in stacks
        assert 'File "' in stacks
        assert worker.poll() is None  # a dump, not a stop
        worker.send_signal(signal.SIGTERM)
        assert worker.wait(timeout=DEADLINE_S) == 128 + signal.SIGTERM  # stopped, not done
    finally:
        if worker.poll() is None:
            worker.kill()
        worker.wait()
        out.close()
        err.close()


@pytest.mark.parametrize("renderer_process", [False, True])
def test_ctrl_c_to_the_group_stops_the_worker_with_130(
    tmp_path: Path, renderer_process: bool
) -> None:
    """A terminal's Ctrl-C reaches the worker and its renderer process alike; the worker
    stops the renderer in order (no traceback from it) and ends with 130."""
    command = [sys.executable, "-m", WORKER_MODULE, "--booth", "signals", "--driver", "null",
               "--control", _free_tcp_endpoint(), "--telemetry", _free_tcp_endpoint(),
               "--livelink-port", "0", "--facecapturex-port", "0",
               *(["--renderer-process"] if renderer_process else [])]  # fmt: skip
    env = {**os.environ, "CHAMELEONS_DATA_DIR": str(tmp_path)}
    worker = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, start_new_session=True)  # fmt: skip
    assert worker.stdout is not None
    assert worker.stderr is not None
    out, err = Lines(worker.stdout), Lines(worker.stderr)
    try:
        out.until("Ctrl-C stops")  # started: the signal handlers are in place
        os.killpg(worker.pid, signal.SIGINT)
        assert worker.wait(timeout=DEADLINE_S) == 128 + signal.SIGINT
    finally:
        if worker.poll() is None:
            worker.kill()
        worker.wait()
        out.close()
        err.close()
    logged = []
    while not err.queue.empty():
        logged.append(err.queue.get())
    assert not [line for line in logged if "Traceback" in line], "".join(logged)
