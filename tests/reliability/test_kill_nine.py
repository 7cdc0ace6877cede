"""``kill -9`` of the server and of the worker mid-session, as real processes started the
way a lab starts them (``chameleons serve`` and ``chameleons worker``), on SQLite and
PostgreSQL: every answer the phone got an acknowledgement for is in the database after
each kill, and after a restart the same session runs to its end.

The scripted wizard and phone (``drive_session``) keep their HTTP clients across the kills:
the staff login is a server-side session in the database, so it survives the restart.
"""

from __future__ import annotations

import os
import random
import secrets
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import httpx
import pytest
from sqlalchemy import Engine, select

from chameleons.backend.models import Interaction, QuestionnaireResponse
from chameleons.backend.models import Session as SessionRow
from tests.support.bots import ParticipantBot, WizardBot, drive_session, staff_api, study_with_plan

pytestmark = pytest.mark.slow
READY_TIMEOUT = 120.0


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


class Process:
    """One ``chameleons`` command as a child process, its output in a log file."""

    def __init__(self, name: str, args: list[str], env: dict[str, str], logs: Path) -> None:
        self.name, self.args, self.env = name, args, env
        self.log_path = logs / f"{name}.log"
        self.proc: subprocess.Popen[bytes] | None = None
        self._log: IO[bytes] | None = None

    def start(self) -> None:
        self._log = self.log_path.open("ab")
        command = [str(Path(sys.executable).parent / "chameleons"), *self.args]
        self.proc = subprocess.Popen(command, env=self.env, stdout=self._log, stderr=self._log)

    def kill9(self) -> None:
        assert self.proc is not None
        os.kill(self.proc.pid, signal.SIGKILL)
        assert self.proc.wait(READY_TIMEOUT) == -signal.SIGKILL
        self._close_log()

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._close_log()

    def _close_log(self) -> None:
        if self._log is not None:
            self._log.close()
            self._log = None

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")[-3000:]


def wait_until_ready(server: Process, base: str, http: httpx.Client) -> None:
    """Poll /healthz until the server answers (a readiness poll with a deadline)."""
    deadline = time.monotonic() + READY_TIMEOUT
    while True:
        assert server.proc is not None
        assert server.proc.poll() is None, f"the server exited:\n{server.log()}"
        try:
            if http.get(f"{base}/healthz", timeout=5).status_code == 200:
                return
        except httpx.TransportError:
            pass
        assert time.monotonic() < deadline, f"the server did not come up:\n{server.log()}"
        time.sleep(0.1)


def wait_for_worker(staff_http: httpx.Client, booth: str) -> None:
    """Wait until the server's booth monitor sees the booth's worker."""
    deadline = time.monotonic() + READY_TIMEOUT
    while True:
        booths = {b["booth"]: b for b in staff_http.get("/api/pi/monitor").json()["booths"]}
        if booths.get(booth, {}).get("worker_connected") is True:
            return
        assert time.monotonic() < deadline, f"no worker on {booth}: {booths.get(booth)}"
        time.sleep(0.2)


def wait_for_event(staff_http: httpx.Client, session_id: int, kind: str, after: int) -> int:
    return wait_for_any_event(staff_http, session_id, (kind,), after)


def wait_for_any_event(
    staff_http: httpx.Client, session_id: int, kinds: tuple[str, ...], after: int
) -> int:
    """Wait until the session's timeline has an event of ``kinds`` after event id ``after``;
    returns its id (the server's own record of what it saw, not a guess by time)."""
    deadline = time.monotonic() + READY_TIMEOUT
    while True:
        events = staff_http.get(f"/api/sessions/{session_id}/events?after={after}").json()
        found = [e["id"] for e in events if e["kind"] in kinds]
        if found:
            return int(found[0])
        assert time.monotonic() < deadline, f"no {kinds} event: {[e['kind'] for e in events]}"
        time.sleep(0.2)


def last_event(staff_http: httpx.Client, session_id: int) -> int:
    events = staff_http.get(f"/api/sessions/{session_id}/events?limit=5000").json()
    return int(events[-1]["id"]) if events else 0


@pytest.fixture
def processes(tmp_path: Path, database_url: str) -> Iterator[dict[str, Any]]:
    port, command, telemetry = free_port(), free_port(), free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("CHAMELEONS_")}
    env.update(
        CHAMELEONS_DATABASE_URL=database_url,
        CHAMELEONS_DATA_DIR=str(tmp_path / "data"),
        CHAMELEONS_SECRET_KEY=secrets.token_urlsafe(32),
        CHAMELEONS_WORKER_COMMAND_ENDPOINT=f"tcp://127.0.0.1:{command}",
        CHAMELEONS_WORKER_TELEMETRY_ENDPOINT=f"tcp://127.0.0.1:{telemetry}",
    )
    server = Process("server", ["serve", "--port", str(port), "--no-upgrade"], env, tmp_path)
    worker = Process(
        "worker",
        [
            "worker", "--booth", "booth-1", "--driver", "null",
            "--livelink-port", "0", "--facecapturex-port", "0",
            "--control", f"tcp://127.0.0.1:{command}",
            "--telemetry", f"tcp://127.0.0.1:{telemetry}",
        ],
        env,
        tmp_path,
    )  # fmt: skip
    try:
        yield {"server": server, "worker": worker, "base": f"http://127.0.0.1:{port}"}
    finally:
        worker.stop()
        server.stop()


def acknowledged_answers_are_stored(engine: Engine, session_id: int, phone: ParticipantBot) -> int:
    """Every submission the phone got a receipt for is in the database; returns the count."""
    with engine.connect() as db:
        session = db.execute(select(SessionRow).where(SessionRow.id == session_id)).one()
        rankings: dict[int, Any] = dict(
            db.execute(  # type: ignore[arg-type]
                select(Interaction.position, Interaction.initial_ranking).where(
                    Interaction.session_id == session_id
                )
            ).all()
        )
        stored = {
            (r.position, r.questionnaire, r.item)
            for r in db.execute(
                select(QuestionnaireResponse).where(QuestionnaireResponse.session_id == session_id)
            ).all()
        }
    for sent in phone.sent:
        if sent["kind"] == "consent":
            assert session.consent_at is not None
        elif sent["kind"] == "ranking":
            assert rankings[sent["position"]] == sent["ranking"], sent
        else:
            for item in sent["answers"]:
                assert (sent["position"], sent["questionnaire"], item) in stored, (sent, item)
    return len(phone.sent)


def test_kill_9_of_server_and_worker_loses_no_acknowledged_answer(
    processes: dict[str, Any], engine: Engine
) -> None:
    server, worker, base = processes["server"], processes["worker"], processes["base"]
    server.start()
    worker.start()
    with (
        httpx.Client(base_url=base, timeout=60) as staff_http,
        httpx.Client(base_url=base, timeout=60) as phone_http,
    ):
        wait_until_ready(server, base, staff_http)
        pi = staff_api(staff_http, engine, "pi")
        study_id = study_with_plan(pi, participants=2)
        wait_for_worker(staff_http, "booth-1")
        wizard = WizardBot.create(pi, study_id, booth="booth-1")
        phone = ParticipantBot(phone_http, wizard.token)
        checked: list[int] = []

        def on_step(step: str) -> None:
            if step == "1:answered":  # the server dies right after acknowledging answers
                server.kill9()
                checked.append(acknowledged_answers_are_stored(engine, wizard.session_id, phone))
                server.start()
                wait_until_ready(server, base, staff_http)
                wait_for_worker(staff_http, "booth-1")  # the worker reconnects by itself
            elif step == "2:negotiated":  # the worker dies in the middle of an interaction
                before = last_event(staff_http, wizard.session_id)
                worker.kill9()
                lost = wait_for_event(staff_http, wizard.session_id, "worker.lost", before)
                checked.append(acknowledged_answers_are_stored(engine, wizard.session_id, phone))
                worker.start()
                back = ("worker.restarted", "worker.connected")
                wait_for_any_event(staff_http, wizard.session_id, back, lost)

        result = drive_session(wizard, phone, random.Random(9), on_step=on_step)
        assert result.snapshot["state"] == "complete"
        assert len(checked) == 2
        assert checked[0] >= 3  # consent, the questions before, a ranking, its questionnaire
        total = acknowledged_answers_are_stored(engine, wizard.session_id, phone)
        assert total > checked[1]
    assert "Traceback" not in server.log(), server.log()
