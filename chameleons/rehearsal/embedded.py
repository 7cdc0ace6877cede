"""A whole system on this machine for a rehearsal: the server (in a thread, on a free
loopback port) with its worker bridge and a supervised local worker driving the virtual
robot, plus a simulated face stream standing in for the iPhone.

It uses the configured database (by default the demo's SQLite under the data dir): the
newest active study there, or the demo's study with its 12-row plan when there is none.
The rehearsal logs in as a ``rehearsal-bot`` wizard account whose password is new for
every run and which is switched off again afterwards.
"""

from __future__ import annotations

import secrets
import socket
import subprocess
import threading
import time
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext
from dataclasses import dataclass
from typing import Any

from fastapi import FastAPI
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.app import create_app
from chameleons.backend.auth import repository as users
from chameleons.backend.auth import service as auth
from chameleons.backend.auth.schemas import StaffUserCreate
from chameleons.backend.db import build_engine, build_sessionmaker
from chameleons.backend.migrate import upgrade
from chameleons.backend.models import Study as StudyRow
from chameleons.backend.studies import service as studies
from chameleons.experiment.study import load_default_study, study_from_config
from chameleons.launch.embedded import (
    DEMO_PARTICIPANTS,
    DEMO_PLAN_SEED,
    demo_settings,
    start_face_simulator,
    stop_process,
)
from chameleons.launch.interrupts import Interrupts
from chameleons.launch.ports import free_port
from chameleons.launch.web_server import WebServer, web_config
from chameleons.rehearsal.runner import RehearsalError, Target
from chameleons.settings import Settings

BOT_USERNAME = "rehearsal-bot"
ANY_PORT = "tcp://127.0.0.1:*"
WORKER_HELLO_SECONDS = 30.0


def rehearsal_settings(settings: Settings, port: int) -> Settings:
    """The embedded demo's settings on loopback ports of this run's own, so a running demo
    (or another rehearsal) is not disturbed."""
    return demo_settings(settings).model_copy(
        update={
            "host": "127.0.0.1",
            "port": port,
            "public_url": None,
            "bridge_enabled": True,
            "embedded_worker": True,
            "worker_command_endpoint": ANY_PORT,
            "worker_telemetry_endpoint": ANY_PORT,
            "livelink_port": free_port(settings.capture_bind_host, socket.SOCK_DGRAM),
            "facecapturex_port": 0,
        }
    )


@dataclass(frozen=True)
class Prepared:
    password: str
    study_id: int
    config: dict[str, Any]


def prepare(settings: Settings, study_id: int | None) -> Prepared:
    """Migrate, pick (or create) the study, and give the bot account a fresh password."""
    upgrade(settings.effective_database_url)
    with _transaction(settings) as db:
        study = _study(db, study_id)
        return Prepared(_bot_password(db, active=True), study.id, dict(study.config))


@contextmanager
def _transaction(settings: Settings) -> Iterator[DbSession]:
    """A session on the configured database, committed when the block ends normally."""
    engine = build_engine(settings.effective_database_url)
    try:
        with build_sessionmaker(engine)() as db, db.begin():
            yield db
    finally:
        engine.dispose()


def _study(db: DbSession, study_id: int | None) -> StudyRow:
    if study_id is not None:
        study = db.get(StudyRow, study_id)
        if study is None:
            raise RehearsalError(f"The database has no study {study_id}.")
    else:
        newest = select(StudyRow).order_by(StudyRow.is_active.desc(), StudyRow.id.desc())
        found = db.scalars(newest).first()
        study = found or studies.create_study(db, load_default_study(), DEMO_PLAN_SEED)
        if not studies.plan_rows(db, study.id) and found is None:
            studies.generate_plan(db, study, DEMO_PARTICIPANTS)
    if not studies.plan_rows(db, study.id):
        raise RehearsalError(
            f"Study {study.id} has no plan yet: generate it first (chameleons plan)."
        )
    return study


def _bot_password(db: DbSession, active: bool) -> str:
    password = secrets.token_urlsafe(24)
    user = users.get_by_username(db, BOT_USERNAME)
    if user is None:
        data = StaffUserCreate(username=BOT_USERNAME, password=password, role="wizard")
        user = auth.create_user(db, data)
    else:
        auth.set_password(db, user, password)
    user.is_active = active
    db.flush()
    return password


def retire_bot(settings: Settings) -> None:
    """Switch the bot account off (its password is unknown to anyone after the run)."""
    with _transaction(settings) as db:
        _bot_password(db, active=False)


class ServerThread:
    """uvicorn serving ``app`` on an already bound socket, in a background thread."""

    def __init__(self, app: FastAPI, sock: socket.socket, settings: Settings) -> None:
        config = web_config(app, settings, log_level="warning", lifespan="on")
        self.server = WebServer(config)
        self._sock = sock
        self._thread = threading.Thread(
            target=self.server.run, kwargs={"sockets": [sock]}, name="rehearsal-server"
        )

    def start(self, timeout: float = 30.0) -> None:
        self._thread.start()
        deadline = time.monotonic() + timeout
        while not self.server.started:  # uvicorn offers no event; the join is the wait
            if not self._thread.is_alive() or time.monotonic() > deadline:
                raise RehearsalError("The embedded server did not start.")
            self._thread.join(0.01)

    def request_stop(self, again: bool = False) -> None:
        """Ask the server to shut down (from a signal handler too: it only sets flags)."""
        self.server.stop(again)

    def stop(self) -> None:
        self.request_stop()
        self._thread.join(timeout=30)
        self._sock.close()


def wait_for_worker(app: FastAPI, booth: str, timeout: float = WORKER_HELLO_SECONDS) -> None:
    """Until the supervised worker has said hello to the bridge (polled: no event for it)."""
    ticker = threading.Event()
    deadline = time.monotonic() + timeout
    while booth not in app.state.bridge.workers():
        if time.monotonic() > deadline:
            raise RehearsalError(f"The local worker of {booth} did not start within {timeout:g} s.")
        ticker.wait(0.02)


def _bound_socket() -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(("127.0.0.1", 0))
    return sock


@contextmanager
def embedded_system(
    base: Settings,
    study_id: int | None = None,
    simulate_face: bool = True,
    booth: str | None = None,
    stops: Interrupts | None = None,
) -> Iterator[Target]:
    """Start everything, yield where to rehearse, stop everything (also on Ctrl-C).
    ``booth``: the local worker's booth (default: the settings' embedded worker booth);
    naming it lets the rehearsal use a booth with a real session open. ``stops``: the
    command's stop signals, which shut the server down at once (the rehearsal then ends
    even when the signal's exception was lost on its way)."""
    sock = _bound_socket()
    settings = rehearsal_settings(base, sock.getsockname()[1])
    if booth is not None:
        settings = settings.model_copy(update={"embedded_worker_booth": booth})
    prepared = prepare(settings, study_id)
    app = create_app(settings)
    server = ServerThread(app, sock, settings)
    simulator: subprocess.Popen[bytes] | None = None
    stopping: AbstractContextManager[None] = (
        stops.stopping(server.request_stop) if stops is not None else nullcontext()
    )
    with stopping:
        try:
            server.start()
            wait_for_worker(app, settings.embedded_worker_booth)
            if simulate_face:
                simulator = start_face_simulator(settings, settings.livelink_port)
            spec = study_from_config(prepared.config)
            yield Target(settings.effective_public_url, BOT_USERNAME, prepared.password,
                         prepared.study_id, settings.embedded_worker_booth,
                         booth_chosen=booth is not None, local=True,
                         studies=(spec,))  # fmt: skip
        finally:
            if simulator is not None:
                stop_process(simulator)
            server.stop()
            retire_bot(settings)
