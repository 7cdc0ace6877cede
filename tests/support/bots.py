"""The scripted wizard and participant for tests (the code lives in the package so that
rehearsals can use it too)."""

from argon2 import PasswordHasher
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import StaffUser
from chameleons.backend.sessions.bot import (
    ApiError,
    HttpClient,
    ParticipantBot,
    SessionResult,
    StaffApi,
    WizardBot,
    answers_for,
    drive_session,
    new_client_id,
    run_session,
)

__all__ = [
    "ApiError",
    "HttpClient",
    "ParticipantBot",
    "SessionResult",
    "StaffApi",
    "WizardBot",
    "answers_for",
    "drive_session",
    "new_client_id",
    "run_session",
]


# Tests store cheap argon2 parameters (a verify reads them from the hash): logins stay real
# but take milliseconds instead of the production cost.
_CHEAP_HASHER = PasswordHasher(time_cost=1, memory_cost=64, parallelism=1)
PASSWORD = "a long password"


def add_staff(engine: Engine, username: str, role: str) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        db.add(StaffUser(username=username, password_hash=_CHEAP_HASHER.hash(PASSWORD), role=role))


def staff_api(
    http: HttpClient, engine: Engine, role: str = "wizard", name: str | None = None
) -> StaffApi:
    """A staff member of ``role``, created in the database and logged in via the form."""
    username = name or f"{role}-user"
    add_staff(engine, username, role)
    return StaffApi(http).login(username, PASSWORD)


def study_with_plan(
    pi: StaffApi, participants: int = 12, seed: int = 7, yaml: str | None = None
) -> int:
    """The default study (or the study file ``yaml``), created by the PI with a plan;
    returns its id."""
    body: dict[str, object] = {"plan_seed": seed}
    if yaml is not None:
        body["yaml"] = yaml
    study = pi.post("/api/studies", body)
    pi.post(f"/api/studies/{study['id']}/plan", {"participants": participants})
    return int(study["id"])
