"""`chameleons serve` as a real process. Stopped by Ctrl-C or SIGTERM it shuts down in
order and ends with 130 / 143, whether the signal comes while it starts (its own handler
has it) or once it serves (uvicorn's would have had it: it ended 0 after Ctrl-C). Its
login throttle counts the connection's address unless a proxy is configured as trusted
(uvicorn's default believed X-Forwarded-For from any local process)."""

from __future__ import annotations

import os
import secrets
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

from tests.backend.test_auth import csrf_from

pytestmark = pytest.mark.slow
DEADLINE_S = 120.0  # a fresh process migrating a database on a busy machine, with room


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _serve(tmp_path: Path, port: int, **settings: str) -> subprocess.Popen[str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("CHAMELEONS_")}
    env.update(
        CHAMELEONS_DATA_DIR=str(tmp_path / "data"),
        CHAMELEONS_SECRET_KEY=secrets.token_urlsafe(32),
        CHAMELEONS_WORKER_COMMAND_ENDPOINT="tcp://127.0.0.1:*",
        CHAMELEONS_WORKER_TELEMETRY_ENDPOINT="tcp://127.0.0.1:*",
        PYTHONUNBUFFERED="1",
        **settings,
    )
    command = [sys.executable, "-m", "chameleons", "serve", "--port", str(port)]
    return subprocess.Popen(command, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)  # fmt: skip


def _wait_until_serving(base: str, process: subprocess.Popen[str]) -> None:
    deadline = time.monotonic() + DEADLINE_S
    with httpx.Client(base_url=base, timeout=10, trust_env=False) as http:
        while True:
            assert process.poll() is None, "the server ended before it served"
            try:
                if http.get("/healthz").status_code == 200:
                    return
            except httpx.TransportError:
                pass
            assert time.monotonic() < deadline, "the server never answered /healthz"
            time.sleep(0.1)  # polls the server's answer, bounded by the deadline


@pytest.mark.parametrize("moment", ["starting", "serving"])
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_serve_stopped_by_a_signal_ends_with_128_plus_it(
    tmp_path: Path, signum: int, moment: str
) -> None:
    port = _free_port()
    process = _serve(tmp_path, port)
    try:
        assert process.stdout is not None
        head = process.stdout.readline()  # printed just before the server starts
        assert head.startswith("serving on"), head
        if moment == "serving":
            _wait_until_serving(f"http://127.0.0.1:{port}", process)
        process.send_signal(signum)
        rest = process.communicate(timeout=DEADLINE_S)[0]
        assert process.returncode == 128 + signum, head + rest
        assert "Traceback" not in rest, rest
        if moment == "serving":  # a graceful shutdown: the application's lifespan ended
            assert "Application shutdown complete" in rest, rest
    finally:
        if process.poll() is None:
            process.kill()
        process.communicate()


MAX_FAILURES = 3


@pytest.mark.parametrize("trusted", ["", "127.0.0.1"])
def test_the_login_throttle_believes_forwarded_addresses_only_from_a_configured_proxy(
    tmp_path: Path, trusted: str
) -> None:
    """Failed logins from one local process that names a new X-Forwarded-For address each
    time: without a configured proxy they all count against that process (locked after
    MAX_FAILURES); with it, the forwarded addresses are the proxy's clients, each its own."""
    port = _free_port()
    process = _serve(tmp_path, port, CHAMELEONS_FORWARDED_ALLOW_IPS=trusted,
                     CHAMELEONS_LOGIN_MAX_FAILURES=str(MAX_FAILURES))  # fmt: skip
    base = f"http://127.0.0.1:{port}"
    try:
        _wait_until_serving(base, process)
        statuses = []
        with httpx.Client(base_url=base, timeout=60, trust_env=False) as http:
            for attempt in range(MAX_FAILURES + 2):
                token = csrf_from(http.get("/login").text)
                form = {"username": "pia", "password": "a wrong guess", "csrf_token": token}
                forged = {"X-Forwarded-For": f"198.51.100.{attempt + 1}"}
                statuses.append(http.post("/login", data=form, headers=forged).status_code)
    finally:
        process.terminate()
        process.communicate(timeout=DEADLINE_S)
    if trusted:
        assert statuses == [401] * (MAX_FAILURES + 2)
    else:
        assert statuses == [401] * MAX_FAILURES + [429, 429]
