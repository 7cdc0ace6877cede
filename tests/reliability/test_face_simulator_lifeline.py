"""`chameleons demo` killed with kill -9 leaves no face simulator behind: the simulator it
starts (start_face_simulator, as the demo does) dies with its parent. Real processes."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

DEADLINE = 120.0
PARENT = """
import sys, time
from chameleons.launch.embedded import start_face_simulator
from chameleons.settings import Settings
child = start_face_simulator(Settings(_env_file=None), port=int(sys.argv[1]))
print(child.pid, flush=True)
time.sleep(3600)
"""


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, IndexError):
        return False
    return state not in ("Z", "X")  # a zombie has ended; only its entry waits for a reaper


def test_the_face_simulator_dies_when_the_demo_is_killed(tmp_path: Path) -> None:
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.bind(("127.0.0.1", 0))
    receiver.settimeout(DEADLINE)
    env = {k: v for k, v in os.environ.items() if not k.startswith("CHAMELEONS_")}
    env["CHAMELEONS_DATA_DIR"] = str(tmp_path)
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT, str(receiver.getsockname()[1])],
        env=env, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    child = 0
    try:
        assert parent.stdout is not None
        child = int(parent.stdout.readline())
        receiver.recv(65536)  # the simulator is up: it sends the face
        assert _alive(child)
        parent.send_signal(signal.SIGKILL)
        parent.wait(DEADLINE)
        deadline = time.monotonic() + DEADLINE
        while _alive(child):
            assert time.monotonic() < deadline, "the face simulator outlived its parent"
            time.sleep(0.05)
    finally:
        receiver.close()
        if parent.poll() is None:
            parent.kill()
            parent.wait()
        if parent.stdout is not None:
            parent.stdout.close()
        if child and _alive(child):
            os.kill(child, signal.SIGKILL)
