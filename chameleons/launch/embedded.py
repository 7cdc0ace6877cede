"""The embedded default: demo data in the database and the processes `chameleons demo` runs.

Also used by `chameleons rehearse` when it starts its own system.
"""

from __future__ import annotations

import json
import secrets
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from pydantic import SecretStr
from sqlalchemy import select
from sqlalchemy.orm import Session

from chameleons.backend.auth import repository as users
from chameleons.backend.auth import service as auth
from chameleons.backend.auth.schemas import StaffUserCreate
from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.migrate import upgrade
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.models import Study as StudyRow
from chameleons.backend.sessions import service as sessions
from chameleons.backend.sessions.flow import load as load_flow
from chameleons.backend.studies import service as studies
from chameleons.experiment.study import load_default_study
from chameleons.launch.lifeline import child_env
from chameleons.settings import Settings

DEMO_USERS = (("pi", "pi"), ("wizard", "wizard"))
DEMO_PARTICIPANTS = 12  # one balance period of the default design
DEMO_PLAN_SEED = 2026
DEMO_MAX_JITTER_P99_MS = 20.0


@dataclass(frozen=True)
class DemoData:
    credentials: dict[str, str]
    study_id: int
    session_id: int
    phone_token: str
    participant_code: str


def demo_settings(settings: Settings) -> Settings:
    """Demo mode with a persistent random key and a supervised local worker."""
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    update: dict[str, object] = {"demo_mode": True, "embedded_worker": True}
    if "health_max_jitter_p99_ms" not in settings.model_fields_set:
        # The demo's robot is the browser display on this same machine, which interpolates
        # at the screen's refresh (~17 ms a frame): tick jitter below that is invisible.
        update["health_max_jitter_p99_ms"] = DEMO_MAX_JITTER_P99_MS
    if not settings.secret_key.get_secret_value():
        update["secret_key"] = SecretStr(_demo_secret(settings.data_dir))
    demo = settings.model_copy(update=update)
    _demo_keys(demo)
    return demo


def _demo_keys(settings: Settings) -> None:
    """The demo's server and its local worker talk CURVE too: keys made on first start."""
    from chameleons.worker import curve

    if not curve.have_server_keys(settings.keys_dir):
        curve.create_keys(settings.keys_dir, settings.worker_key_name)


def _demo_secret(data_dir: Path) -> str:
    """A random key kept in the data dir, so demo logins and links survive a restart."""
    path = data_dir / "demo-secret-key"
    if not path.exists():
        path.write_text(secrets.token_urlsafe(32))
        path.chmod(0o600)
    return path.read_text().strip()


class DataDirInUseError(Exception):
    """Another running demo holds the data directory."""


def lock_data_dir(data_dir: Path) -> IO[str]:
    """Hold the data directory for this demo until the returned file is closed: two demos
    on one SQLite file and one booth would drive each other's participant."""
    data_dir.mkdir(parents=True, exist_ok=True)
    handle = (data_dir / "demo.lock").open("w")
    try:
        import fcntl  # POSIX only; elsewhere two demos are not detected
    except ImportError:  # pragma: no cover
        return handle
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        handle.close()
        raise DataDirInUseError(
            f"Another chameleons demo is using the data directory {data_dir.resolve()}: "
            "stop it, or start this one with CHAMELEONS_DATA_DIR set to another folder."
        ) from None
    return handle


def prepare_demo(settings: Settings) -> DemoData:
    """Migrate, then create (once) the demo users, the default study with a 12-row plan,
    and an open session for the next participant; a second run reuses all of it."""
    upgrade(settings.effective_database_url)
    engine = build_engine(settings.effective_database_url)
    try:
        with session_scope(build_sessionmaker(engine)) as db:
            credentials = _demo_users(db, settings.data_dir / "demo-credentials.json")
            study = _demo_study(db)
            session = _open_session(db, study, settings.embedded_worker_booth)
            code = load_flow(db, session.id, lock=False).participant.code
            data = DemoData(credentials, study.id, session.id, session.phone_token, code)
    finally:
        engine.dispose()
    return data


def _demo_users(db: Session, path: Path) -> dict[str, str]:
    stored: dict[str, str] = json.loads(path.read_text()) if path.exists() else {}
    for username, role in DEMO_USERS:
        password = stored.get(username) or secrets.token_urlsafe(9)
        user = users.get_by_username(db, username)
        if user is None:
            auth.create_user(db, StaffUserCreate(username=username, password=password, role=role))
        elif username not in stored:
            auth.set_password(db, user, password)
        stored[username] = password
    path.write_text(json.dumps(stored, indent=2))
    path.chmod(0o600)
    return stored


def _demo_study(db: Session) -> StudyRow:
    spec = load_default_study()
    study = db.scalars(
        select(StudyRow).where(StudyRow.config_hash == spec.content_hash).order_by(StudyRow.id)
    ).first()
    if study is None:
        study = studies.create_study(db, spec, plan_seed=DEMO_PLAN_SEED)
    if not studies.plan_rows(db, study.id):
        studies.generate_plan(db, study, DEMO_PARTICIPANTS)
    return study


def _open_session(db: Session, study: StudyRow, booth: str) -> SessionRow:
    """The newest session not yet complete, else one for a newly registered participant."""
    session = db.scalars(
        select(SessionRow)
        .where(SessionRow.study_id == study.id, SessionRow.state != "complete")
        .order_by(SessionRow.id.desc())
    ).first()
    if session is not None:
        return session
    if studies.next_free_row(db, study) is None:
        studies.generate_plan(db, study, len(studies.plan_rows(db, study.id)) + DEMO_PARTICIPANTS)
    participant = studies.register_participant(db, study)
    return sessions.create_session(db, study, participant, booth=booth).session


def start_face_simulator(
    settings: Settings, port: int | None = None, *, follow_cues: bool = False
) -> subprocess.Popen[bytes]:
    """A synthetic face sent as Live Link Face UDP to the local worker (the iPhone's part);
    with ``follow_cues`` it reads the booth check's moves on its standard input
    (:class:`FaceSimulatorCues` writes them)."""
    target = f"127.0.0.1:{port or settings.livelink_port}"
    command = [sys.executable, "-m", "chameleons", "simulate-face", "--target", target]
    command += ["--follow-cues"] if follow_cues else []
    # It ends with this process, even on kill -9 (lifeline.die_with_parent in the child).
    stdin = subprocess.PIPE if follow_cues else subprocess.DEVNULL
    return subprocess.Popen(command, stdin=stdin, env=child_env())


class FaceSimulatorCues:
    """The booth check's moves to a face simulator that follows cues (``state.face_cues``):
    the demo's simulated participant turns and nods when the check asks. Only its booth."""

    def __init__(self, process: subprocess.Popen[bytes], booth: str) -> None:
        self.process, self.booth = process, booth

    def __call__(self, booth: str, move: str, seconds: float) -> None:
        stdin = self.process.stdin
        if booth != self.booth or stdin is None or self.process.poll() is not None:
            return
        line = json.dumps({"move": move, "seconds": seconds}) + "\n"
        try:  # a short line into a pipe the simulator drains: does not block
            stdin.write(line.encode())
            stdin.flush()
        except OSError:  # the simulator ended: the check then sees no movement, and says so
            pass


def stop_process(process: subprocess.Popen[bytes], timeout: float = 5.0) -> None:
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
