"""`chameleons rehearse`: on an embedded system it starts itself, and against a running
server with a staff login; refused logins and missing credentials say what is wrong."""

from __future__ import annotations

import os
import secrets
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from click.testing import CliRunner
from sqlalchemy import select

from chameleons.backend.db import build_engine, build_sessionmaker
from chameleons.backend.models import Participant, Session, StaffUser
from chameleons.backend.sessions.bot import StaffApi
from chameleons.cli.main import cli
from chameleons.rehearsal.embedded import BOT_USERNAME, embedded_system
from chameleons.settings import Settings

pytestmark = pytest.mark.slow


def _sessions(settings: Settings) -> list[tuple[str, str, bool]]:
    """(participant code, session state, rehearsal) of every session in the database."""
    engine = build_engine(settings.effective_database_url)
    try:
        with build_sessionmaker(engine)() as db:
            query = select(Participant.code, Session.state, Session.is_rehearsal).join(
                Participant, Participant.id == Session.participant_id
            )
            return [tuple(row) for row in db.execute(query.order_by(Session.id))]
    finally:
        engine.dispose()


def _bot_active(settings: Settings) -> bool | None:
    engine = build_engine(settings.effective_database_url)
    try:
        with build_sessionmaker(engine)() as db:
            query = select(StaffUser.is_active).where(StaffUser.username == BOT_USERNAME)
            return db.scalars(query).first()
    finally:
        engine.dispose()


def test_without_a_server_it_starts_one_and_stops_it(tmp_path: Path) -> None:
    data = tmp_path / "data"
    env = {"CHAMELEONS_DATA_DIR": str(data)}
    args = ["rehearse", "-n", "2", "--script", "silent", "--pattern", "random", "--seed", "4"]
    result = CliRunner().invoke(cli, args, env=env, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert "Rehearsed 2 sessions (2 participants, R001-R002)" in result.output
    assert "chameleons export --include-rehearsal" in result.output
    settings = Settings(data_dir=data, _env_file=None)
    assert _sessions(settings) == [("R001", "complete", True), ("R002", "complete", True)]
    assert _bot_active(settings) is False, "the bot account stays usable after the run"


def test_against_a_running_server_with_a_staff_login(tmp_path: Path) -> None:
    settings = Settings(data_dir=tmp_path / "data", secret_key=secrets.token_urlsafe(32),
                        _env_file=None)  # fmt: skip
    runner = CliRunner()
    with embedded_system(settings, simulate_face=False) as target:
        login = ["--server", target.base_url, "--username", target.username]
        args = ["rehearse", "-n", "1", "--script", "brief", *login, "--booth", target.booth]
        result = runner.invoke(cli, [*args, "--password", target.password])
        assert result.exit_code == 0, result.output
        assert "Rehearsed 1 session (1 participant, R001)" in result.output
        assert "prompts voiced" in result.output
        refused = runner.invoke(cli, [*args, "--password", "not the password"])
        assert refused.exit_code == 1
        assert f"Cannot log in to {target.base_url}" in refused.output
    assert _sessions(settings) == [("R001", "complete", True)]


def test_a_server_needs_a_login() -> None:
    result = CliRunner().invoke(cli, ["rehearse", "-n", "1", "--server", "http://127.0.0.1:9"])
    assert result.exit_code == 2
    assert "--server needs --username and --password" in result.output


def _live_processes() -> dict[int, tuple[int, str]]:
    """Live (not zombie) processes: pid -> (parent pid, command line) (Linux /proc)."""
    processes = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            command = (stat.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except (FileNotFoundError, ProcessLookupError):
            continue
        if fields[0] != "Z":  # fields: state, ppid, ...
            processes[int(stat.parent.name)] = (int(fields[1]), command)
    return processes


def _family(root: int) -> dict[int, str]:
    """``root`` and its live descendants (the worker runs in a session of its own, so
    descent, not the session, says what a command started)."""
    processes = _live_processes()
    family = {pid: command for pid, (_, command) in processes.items() if pid == root}
    grew = True
    while grew:
        children = {
            pid: command
            for pid, (parent, command) in processes.items()
            if parent in family and pid not in family
        }
        family.update(children)
        grew = bool(children)
    return family


def _carrying(data_dir: str) -> dict[int, str]:
    """Live processes whose environment names ``data_dir``: what a command run with it
    started, found even after the command is gone (its children then have another parent)."""
    marker = f"CHAMELEONS_DATA_DIR={data_dir}".encode()
    found = {}
    for pid, (_, command) in _live_processes().items():
        try:
            environment = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
        except (FileNotFoundError, ProcessLookupError, PermissionError):
            continue
        if marker in environment:
            found[pid] = command
    return found


def _still_alive(pids: dict[int, str]) -> dict[int, str]:
    processes = _live_processes()
    return {pid: command for pid, command in pids.items() if pid in processes}


STOPS = {  # how the command is stopped -> the status it must end with
    "ctrl-c": 130,  # a terminal's Ctrl-C: SIGINT to the whole process group
    "sigint": 130,  # `kill -INT PID`: only the command itself
    "kill": 143,  # `kill PID` (SIGTERM): only the command itself
}
MOMENTS = {  # the line after which the signal is sent
    "starting": "Starting an embedded server",  # nothing serves yet: start-up is cut short
    "running": "1/50",  # the first session is done: the server and worker run
}


@pytest.mark.parametrize("moment", sorted(MOMENTS))
@pytest.mark.parametrize("stop", sorted(STOPS))
def test_ctrl_c_or_sigterm_stops_everything_it_started(
    tmp_path: Path, stop: str, moment: str
) -> None:
    """Whenever the signal comes, the command stops what it started and says it was stopped
    (130 / 143, never 0: a script chaining `rehearse` and `export` must not go on)."""
    env = {**os.environ, "CHAMELEONS_DATA_DIR": str(tmp_path / "data"), "PYTHONUNBUFFERED": "1"}
    command = [sys.executable, "-m", "chameleons", "rehearse", "-n", "50", "--script", "silent"]
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, text=True,
                               stderr=subprocess.STDOUT, start_new_session=True)  # fmt: skip
    started: dict[int, str] = {}
    try:
        assert process.stdout is not None
        output = []
        for line in process.stdout:  # the line is the event to act on
            output.append(line)
            if MOMENTS[moment] in line:
                break
        started = _family(process.pid)
        if moment == "running":
            assert len(started) >= 3, output  # itself, worker, face
        if stop == "ctrl-c":
            os.killpg(process.pid, signal.SIGINT)
        else:
            process.send_signal(signal.SIGINT if stop == "sigint" else signal.SIGTERM)
        # Generous deadlines (events, not durations, end the waits): at load 7-12 on two
        # cores the shutdown took longer than 30 s.
        rest = process.communicate(timeout=180)[0]
        assert process.returncode == STOPS[stop], "".join(output) + rest
        assert "Traceback" not in rest, rest
        started.update(_carrying(env["CHAMELEONS_DATA_DIR"]))  # also any started after
        deadline = time.monotonic() + 60  # children may take a moment after the parent
        while _still_alive(started) and time.monotonic() < deadline:
            time.sleep(0.05)  # polls /proc with a deadline; not a fixed wait
        assert _still_alive(started) == {}
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        for pid in _still_alive(started):
            os.kill(pid, signal.SIGKILL)  # what a failed run left behind
        if process.stdout is not None:
            process.stdout.close()


def test_a_booth_with_a_real_session_open_is_refused_unless_named(tmp_path: Path) -> None:
    settings = Settings(data_dir=tmp_path / "data", secret_key=secrets.token_urlsafe(32),
                        _env_file=None)  # fmt: skip
    runner = CliRunner()
    with (
        embedded_system(settings, simulate_face=False) as target,
        httpx.Client(base_url=target.base_url, timeout=60, trust_env=False) as http,
    ):
        staff = StaffApi(http).login(target.username, target.password)
        real = staff.post("/api/sessions", {"study_id": target.study_id, "booth": target.booth})
        code = real["participant"]["code"]
        login = ["--server", target.base_url, "--username", target.username,
                 "--password", target.password]  # fmt: skip
        args = ["rehearse", "-n", "1", "--script", "silent", *login]
        refused = runner.invoke(cli, args)
        assert refused.exit_code == 1, refused.output
        assert refused.output.strip().splitlines() == [
            f"Error: Booth {target.booth} has a real session open (session {real['id']}, "
            f"participant {code}, pending): rehearse on another booth with --booth NAME, or "
            f"name this one (--booth {target.booth}) to rehearse there anyway."
        ]
        assert len(_sessions(settings)) == 1  # nothing was rehearsed

        named = runner.invoke(cli, [*args, "--booth", target.booth])
        assert named.exit_code == 0, named.output
        assert f"Warning: Booth {target.booth} has a real session open" in named.output
        assert "Rehearsed 1 session (1 participant, R001)" in named.output
    assert _sessions(settings) == [(code, "pending", False), ("R001", "complete", True)]
