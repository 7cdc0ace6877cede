"""A start-up failure of `chameleons demo` is one clear sentence before anything else is
printed (no welcome, no passwords, no traceback), and invalid settings are one sentence per
bad setting naming its ``CHAMELEONS_`` variable (or the option it came from)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import click
import pytest
from fastapi import FastAPI

from chameleons.cli.common import load_settings
from chameleons.cli.startup import QuietStartup, StartupError, serve
from chameleons.launch.interrupts import Interrupts
from chameleons.settings import Settings

SETTINGS = Settings(_env_file=None)


def _demo(tmp_path: Path, **env: str) -> subprocess.CompletedProcess[str]:
    """`chameleons demo` to its end, with loopback ports of its own unless ``env`` says."""
    environment = {
        **os.environ, "CHAMELEONS_DATA_DIR": str(tmp_path / "data"), "PYTHONUNBUFFERED": "1",
        "CHAMELEONS_WORKER_COMMAND_ENDPOINT": "tcp://127.0.0.1:*",
        "CHAMELEONS_WORKER_TELEMETRY_ENDPOINT": "tcp://127.0.0.1:*",
        "CHAMELEONS_LIVELINK_PORT": "0", "CHAMELEONS_FACECAPTUREX_PORT": "0", **env,
    }  # fmt: skip
    command = [sys.executable, "-m", "chameleons", "demo", "--no-simulate-face", "--port",
               str(_free_tcp_port())]  # fmt: skip
    return subprocess.run(command, env=environment, capture_output=True, text=True,
                          timeout=180, stdin=subprocess.DEVNULL, cwd=tmp_path,
                          check=False)  # fmt: skip


def _free_tcp_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _one_sentence(done: subprocess.CompletedProcess[str]) -> str:
    assert done.returncode == 1, done
    assert done.stdout == ""  # no welcome, no URLs, no passwords
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("Error: ")
    assert lines[0].endswith(".")
    return lines[0]


@pytest.mark.slow
def test_a_worker_link_that_cannot_bind_is_one_sentence_before_the_welcome(
    tmp_path: Path,
) -> None:
    """The bind happens in the server's start-up (an ipc path in a folder that is not there
    is found only then): the welcome waits for it."""
    endpoint = f"ipc://{tmp_path}/no-such-folder/commands"
    sentence = _one_sentence(_demo(tmp_path, CHAMELEONS_WORKER_COMMAND_ENDPOINT=endpoint))
    assert sentence == (
        f"Error: Cannot bind the worker endpoints {endpoint} and tcp://127.0.0.1:* "
        "(No such file or directory): set CHAMELEONS_WORKER_COMMAND_ENDPOINT and "
        "CHAMELEONS_WORKER_TELEMETRY_ENDPOINT to endpoints this computer can bind."
    )


def test_an_address_this_computer_does_not_have_is_one_sentence_naming_the_setting(
    tmp_path: Path,
) -> None:
    done = _demo(tmp_path, CHAMELEONS_WORKER_TELEMETRY_ENDPOINT="tcp://192.0.2.1:5556")
    assert _one_sentence(done) == (
        "Error: Cannot listen on 192.0.2.1:5556 (CHAMELEONS_WORKER_TELEMETRY_ENDPOINT): "
        "Cannot assign requested address."
    )
    capture = _demo(tmp_path, CHAMELEONS_CAPTURE_BIND_HOST="192.0.2.1")
    assert "(CHAMELEONS_LIVELINK_PORT with CHAMELEONS_CAPTURE_BIND_HOST=192.0.2.1)" in (
        _one_sentence(capture)
    )


def test_invalid_settings_are_one_sentence_each_naming_the_variable(tmp_path: Path) -> None:
    done = _demo(tmp_path, CHAMELEONS_WS_QUEUE_LIMIT="2", CHAMELEONS_MIRROR="maybe")
    assert done.returncode == 1
    assert done.stdout == ""
    assert done.stderr.strip().splitlines() == [
        "Error: CHAMELEONS_WS_QUEUE_LIMIT is '2': input should be greater than or equal to 8.",
        "CHAMELEONS_MIRROR is 'maybe': input should be a valid boolean, unable to interpret input.",
    ]


def test_a_setting_from_an_option_names_the_option_and_a_secret_is_never_repeated(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("CHAMELEONS_WORKER_FURHAT_FACES", "face-1=Isabel")
    with pytest.raises(click.ClickException) as unreadable:
        load_settings()
    assert unreadable.value.message == (
        'CHAMELEONS_WORKER_FURHAT_FACES cannot be read: it must be JSON, e.g. {"face-1": "Isabel"}.'
    )
    monkeypatch.delenv("CHAMELEONS_WORKER_FURHAT_FACES")
    with pytest.raises(click.ClickException) as refused:
        load_settings(port=70000, worker_robot_key=["hunter2-secret"])
    assert refused.value.message.splitlines() == [
        "--port is '70000': input should be less than or equal to 65535.",
        "--worker-robot-key: input should be a valid string.",
    ]


def _app(fail: bool, log: list[str]) -> FastAPI:
    @asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        log.append("lifespan started")
        if fail:
            raise OSError("the database is on fire")
        yield

    return FastAPI(lifespan=lifespan)


def test_a_failing_start_up_is_a_sentence_and_the_welcome_is_never_called(
    capfd: pytest.CaptureFixture[str],
) -> None:
    log: list[str] = []
    server = QuietStartup(
        _app(True, log), lambda: log.append("welcome"), SETTINGS, log_level="warning"
    )
    with socket.create_server(("127.0.0.1", 0)) as web, pytest.raises(StartupError) as failed:
        serve(server, Interrupts(), [web])
    assert str(failed.value) == "The server could not start: OSError: the database is on fire."
    assert log == ["lifespan started"]
    printed = capfd.readouterr()
    assert "Traceback" not in printed.err + printed.out  # uvicorn's dump is held back


def test_the_welcome_comes_once_the_start_up_is_done() -> None:
    log: list[str] = []

    def welcome() -> None:
        log.append("welcome")
        server.should_exit = True  # the test is over once the welcome came

    server = QuietStartup(_app(False, log), welcome, SETTINGS, log_level="warning")
    with socket.create_server(("127.0.0.1", 0)) as web:
        serve(server, Interrupts(), [web])
    assert log == ["lifespan started", "welcome"]
