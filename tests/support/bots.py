"""The scripted wizard and participant for tests (the code lives in the package so that
rehearsals can use it too)."""

from chameleons.backend.sessions.bot import (
    ApiError,
    ParticipantBot,
    SessionResult,
    StaffApi,
    WizardBot,
    answers_for,
    new_client_id,
    run_session,
)
from tests.backend.test_auth import add_user

__all__ = [
    "ApiError",
    "ParticipantBot",
    "SessionResult",
    "StaffApi",
    "WizardBot",
    "answers_for",
    "new_client_id",
    "run_session",
]


def staff_api(
    client: object, engine: object, role: str = "wizard", name: str | None = None
) -> StaffApi:
    """A staff member of ``role``, created in the database and logged in via the form."""
    username = name or f"{role}-user"
    add_user(engine, username, "a long password", role)  # type: ignore[arg-type]
    return StaffApi(client).login(username, "a long password")  # type: ignore[arg-type]


def study_with_plan(pi: StaffApi, participants: int = 12, seed: int = 7) -> int:
    """The default study, created by the PI with a plan; returns its id."""
    study = pi.post("/api/studies", {"plan_seed": seed})
    pi.post(f"/api/studies/{study['id']}/plan", {"participants": participants})
    return int(study["id"])
