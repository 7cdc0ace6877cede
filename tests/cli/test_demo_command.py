"""`chameleons demo` as a newcomer runs it: a real process on a free port with a fresh data
dir. Its printed links answer as they should, its printed accounts log in, Ctrl-C stops
every process it started, and a second run reuses the data."""

from __future__ import annotations

import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import httpx
import pytest

from chameleons.backend.sessions.bot import StaffApi

pytestmark = pytest.mark.slow
START_SECONDS = 60.0
URL_LINE = re.compile(r"^\s+(wizard console|robot display|PI dashboard|participant)\s+(\S+)")
ACCOUNT_LINE = re.compile(r"^\s+(\w+)\s+password: (\S+)$")
LAST_LINE = "Ctrl-C stops everything."


def _free_port(kind: socket.SocketKind) -> int:
    with socket.socket(socket.AF_INET, kind) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@dataclass
class Demo:
    process: subprocess.Popen[str]
    base: str
    lines: queue.Queue[str] = field(default_factory=queue.Queue)
    output: list[str] = field(default_factory=list)
    urls: dict[str, str] = field(default_factory=dict)
    accounts: dict[str, str] = field(default_factory=dict)
    pump: threading.Thread | None = None

    def read_welcome(self) -> None:
        """Everything up to the welcome's last line (an event: the process printed it)."""
        deadline = time.monotonic() + START_SECONDS
        while not self.output or LAST_LINE not in self.output[-1]:
            remaining = deadline - time.monotonic()
            assert remaining > 0, "no welcome:\n" + "\n".join(self.output)
            try:
                self.output.append(self.lines.get(timeout=remaining))
            except queue.Empty:
                continue
            if match := URL_LINE.match(self.output[-1]):
                self.urls[match.group(1)] = match.group(2)
            elif match := ACCOUNT_LINE.match(self.output[-1]):
                self.accounts[match.group(1)] = match.group(2)

    def wait_healthy(self) -> None:
        """Poll /healthz (the server offers no other signal that it listens)."""
        deadline = time.monotonic() + START_SECONDS
        while True:
            assert self.process.poll() is None, "\n".join(self.output)
            try:
                if httpx.get(f"{self.base}/healthz", timeout=2).status_code == 200:
                    return
            except httpx.TransportError:
                pass
            assert time.monotonic() < deadline, "the demo server never answered /healthz"
            threading.Event().wait(0.05)


def _children(pid: int) -> set[int]:
    """Every live descendant of ``pid`` (Linux /proc)."""
    found: set[int] = set()
    pending = [pid]
    while pending:
        parent = pending.pop()
        # Per thread: a child started from another thread is listed under that thread.
        listed = Path(f"/proc/{parent}/task").glob("*/children")
        kids = [int(pid) for path in listed for pid in _read(path).split()]
        found.update(kids)
        pending.extend(kids)
    return found


def _read(path: Path) -> str:
    try:
        return path.read_text()
    except (FileNotFoundError, ProcessLookupError):  # the thread or process has just ended
        return ""


def _alive(pid: int) -> bool:
    """Running (a zombie has exited; only its parent has not collected it yet)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError, IndexError):
        return False
    return state != "Z"


def _command_line(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except FileNotFoundError:
        return ""


@pytest.fixture
def data_dir(tmp_path: Path) -> Path:
    return tmp_path / "data"


def _start(data_dir: Path, simulate_face: bool, **env_overrides: str) -> Demo:
    return _launch(data_dir, simulate_face, (), env_overrides)


def _launch(data_dir: Path, simulate_face: bool, extra_args: tuple[str, ...],
            env_overrides: dict[str, str]) -> Demo:  # fmt: skip
    port = _free_port(socket.SOCK_STREAM)
    env = {
        **os.environ,
        "CHAMELEONS_DATA_DIR": str(data_dir),
        # Loopback ports of this test's own, so a demo running elsewhere is not disturbed.
        "CHAMELEONS_WORKER_COMMAND_ENDPOINT": "tcp://127.0.0.1:*",
        "CHAMELEONS_WORKER_TELEMETRY_ENDPOINT": "tcp://127.0.0.1:*",
        "CHAMELEONS_LIVELINK_PORT": str(_free_port(socket.SOCK_DGRAM)),
        "CHAMELEONS_FACECAPTUREX_PORT": "0",
        "PYTHONUNBUFFERED": "1",
        **env_overrides,
    }
    flag = "--simulate-face" if simulate_face else "--no-simulate-face"
    command = [sys.executable, "-m", "chameleons", "demo", "--port", str(port), flag,
               *extra_args]  # fmt: skip
    process = subprocess.Popen(
        command,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        stdin=subprocess.DEVNULL,
        text=True,
        cwd=data_dir.parent,
    )
    demo = Demo(process, f"http://127.0.0.1:{port}")
    demo.pump = threading.Thread(target=_pump, args=(process, demo.lines), daemon=True)
    demo.pump.start()
    return demo


def _pump(process: subprocess.Popen[str], lines: queue.Queue[str]) -> None:
    assert process.stdout is not None
    for line in process.stdout:
        lines.put(line.rstrip("\n"))


@pytest.fixture
def demos() -> Iterator[list[Demo]]:
    """Started demos; whatever a failed test left running is ended by its id."""
    started: list[Demo] = []
    yield started
    for demo in started:
        if demo.process.poll() is None:
            leftovers = _children(demo.process.pid)
            demo.process.kill()
            demo.process.wait()
            for pid in leftovers:
                if _alive(pid):
                    os.kill(pid, signal.SIGKILL)
        if demo.pump is not None:
            demo.pump.join(timeout=10)  # the pipe is at its end once the process is gone
        if demo.process.stdout is not None:
            demo.process.stdout.close()


def _check_links(demo: Demo) -> None:
    with httpx.Client(timeout=10) as anonymous:
        for name in ("wizard console", "PI dashboard"):
            answer = anonymous.get(demo.urls[name])
            assert answer.status_code == 303, (name, answer.status_code)
            assert answer.headers["location"].startswith("/login?next="), name
        phone = anonymous.get(demo.urls["participant"])
        assert phone.status_code == 200
        assert "phone/phone.js" in phone.text
        display = anonymous.get(demo.urls["robot display"])
        assert display.status_code == 200
        assert "display/display.js" in display.text


def _check_logins(demo: Demo) -> None:
    assert set(demo.accounts) == {"pi", "wizard"}, demo.output
    for username, password in demo.accounts.items():
        with httpx.Client(base_url=demo.base, timeout=10) as http:
            StaffApi(http).login(username, password)
            assert http.get(demo.urls["wizard console"]).status_code == 200
            assert http.get("/api/staff/me").json()["username"] == username


def _stop(demo: Demo, expected_children: set[str], signum: int = signal.SIGINT) -> None:
    """Ctrl-C (or ``signum``); afterwards neither the demo nor anything it started still
    runs, and it ended with 128 + the signal."""
    children = _children(demo.process.pid)
    commands = {pid: _command_line(pid) for pid in children}
    started = {name for name in expected_children if any(name in c for c in commands.values())}
    assert started == expected_children, commands
    demo.process.send_signal(signum)
    # 130 / 143, not 0: the demo was stopped, it did not finish (a script can tell).
    assert demo.process.wait(timeout=30) == 128 + signum, "\n".join(demo.output)
    still = {pid: commands[pid] for pid in children if _alive(pid)}
    assert not still, f"left running after Ctrl-C: {still}"


def test_the_demo_serves_its_links_logs_in_stops_cleanly_and_reuses_its_data(
    data_dir: Path, demos: list[Demo]
) -> None:
    data_dir.mkdir(parents=True)
    first = _start(data_dir, simulate_face=False)
    demos.append(first)
    first.read_welcome()
    first.wait_healthy()
    _check_links(first)
    _check_logins(first)
    _stop(first, {"chameleons.cli.worker_command"})

    again = _start(data_dir, simulate_face=True)
    demos.append(again)
    again.read_welcome()
    again.wait_healthy()
    assert again.accounts == first.accounts
    link = {name: url.split("/", 3)[-1] for name, url in again.urls.items()}
    assert link == {name: url.split("/", 3)[-1] for name, url in first.urls.items()}
    _check_logins(again)
    _stop(again, {"chameleons.cli.worker_command", "simulate-face"})


def _held(kind: socket.SocketKind) -> socket.socket:
    """A loopback port of this test's own, held (listening for TCP) so it is in use."""
    sock = socket.socket(socket.AF_INET, kind)
    sock.bind(("127.0.0.1", 0))
    if kind == socket.SOCK_STREAM:
        sock.listen()
    return sock


def _run_to_end(data_dir: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "CHAMELEONS_DATA_DIR": str(data_dir), "PYTHONUNBUFFERED": "1"}
    command = [sys.executable, "-m", "chameleons", "demo", "--no-simulate-face", *args]
    return subprocess.run(command, env=env, capture_output=True, text=True, timeout=120,
                          stdin=subprocess.DEVNULL, cwd=data_dir.parent, check=False)  # fmt: skip


def test_a_taken_web_port_is_one_sentence_before_anything_else(data_dir: Path) -> None:
    with _held(socket.SOCK_STREAM) as taken:
        port = taken.getsockname()[1]
        done = _run_to_end(data_dir, "--port", str(port))
    assert done.returncode == 1
    assert done.stdout == ""  # no welcome, no URLs, no passwords
    assert done.stderr.strip().splitlines() == [
        f"Error: Port {port} on 127.0.0.1 is in use (another chameleons demo or server?): "
        "choose another with --port."
    ]


def test_taken_worker_and_capture_ports_move_and_a_shared_data_dir_is_refused(
    data_dir: Path, demos: list[Demo]
) -> None:
    with _held(socket.SOCK_STREAM) as control, _held(socket.SOCK_DGRAM) as livelink, \
            _held(socket.SOCK_STREAM) as facecapturex:  # fmt: skip
        held = {"control": control.getsockname()[1], "livelink": livelink.getsockname()[1],
                "facecapturex": facecapturex.getsockname()[1]}  # fmt: skip
        demo = _start(data_dir, True, **{
            "CHAMELEONS_WORKER_COMMAND_ENDPOINT": f"tcp://127.0.0.1:{held['control']}",
            "CHAMELEONS_LIVELINK_PORT": str(held["livelink"]),
            "CHAMELEONS_FACECAPTUREX_PORT": str(held["facecapturex"]),
        })  # fmt: skip
        demos.append(demo)
        demo.read_welcome()
        demo.wait_healthy()
    text = "\n".join(demo.output)
    moved = re.search(r"Live Link Face \(UDP\): port (\d+) in use, using (\d+)", text)
    assert moved is not None, text
    assert int(moved.group(1)) == held["livelink"]
    livelink_port = moved.group(2)
    assert f"FaceCaptureX (TCP): port {held['facecapturex']} in use, using" in text
    assert f"worker control (ZeroMQ): tcp://127.0.0.1:{held['control']} in use, using" in text
    # The worker listens where the welcome says, and the simulated face is sent there.
    deadline = time.monotonic() + START_SECONDS
    while True:
        commands = [_command_line(pid) for pid in _children(demo.process.pid)]
        worker = [c for c in commands if "chameleons.cli.worker_command" in c]
        face = [c for c in commands if "simulate-face" in c]
        if worker and face:
            break
        assert time.monotonic() < deadline, commands
        threading.Event().wait(0.1)
    assert f"--livelink-port {livelink_port} " in worker[0] + " "
    assert f"--target 127.0.0.1:{livelink_port}" in face[0]
    # A second demo on the same data directory would drive the same participant: refused.
    second = _run_to_end(data_dir)
    assert second.returncode == 1
    assert second.stdout == ""
    assert "Another chameleons demo is using the data directory" in second.stderr
    _stop(demo, {"chameleons.cli.worker_command", "simulate-face"})


def _printed_livelink_port(demo: Demo) -> int:
    text = "\n".join(demo.output)
    printed = re.search(r"iPhone face\s+Live Link Face UDP (\d+),", text)
    assert printed is not None, text
    return int(printed.group(1))


def _udp_in_use(port: int) -> bool:
    """Whether something listens on UDP ``port`` (on every address, as the worker does)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind(("0.0.0.0", port))
        except OSError:
            return True
    return False


def test_livelink_port_zero_means_a_free_port_the_worker_and_the_simulated_face_share(
    data_dir: Path, demos: list[Demo]
) -> None:
    demo = _start(data_dir, True, CHAMELEONS_LIVELINK_PORT="0")
    demos.append(demo)
    demo.read_welcome()
    port = _printed_livelink_port(demo)
    assert port != 0
    deadline = time.monotonic() + START_SECONDS
    while True:
        commands = [_command_line(pid) for pid in _children(demo.process.pid)]
        worker = [c for c in commands if "chameleons.cli.worker_command" in c]
        face = [c for c in commands if "simulate-face" in c]
        if worker and face and _udp_in_use(port):
            break
        assert time.monotonic() < deadline, (port, commands)
        threading.Event().wait(0.1)
    assert f"--livelink-port {port} " in worker[0] + " "  # the worker listens there
    assert f"--target 127.0.0.1:{port}" in face[0]  # and the simulated face sends there
    assert "is not HOST:PORT" not in "\n".join(demo.output)
    _stop(demo, {"chameleons.cli.worker_command", "simulate-face"}, signal.SIGTERM)
