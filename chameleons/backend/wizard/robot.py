"""Put the robot in the interaction's condition and face: ``set_behaviour`` and ``set_face``
to the booth's worker, both logged (``robot.applied`` or ``robot.not_applied``).

The console calls this when an interaction starts and after a condition switch, and the
wizard can repeat it by hand. Behaviour parameters a condition needs (e.g. the recording
``natural`` replays) come from ``app.state.behaviour_params[condition]`` when the server
provides them; without them the worker's own defaults apply, and a refusal is shown.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from chameleons.backend.events import repository as events
from chameleons.backend.models import Event
from chameleons.backend.studies.errors import ConflictError, NotFoundError
from chameleons.backend.wizard import repository, worker_link
from chameleons.backend.wizard.playback import read, write
from chameleons.backend.wizard.service import Outcome
from chameleons.worker.control import SET_BEHAVIOUR, SET_FACE

APPLIED = "robot.applied"
NOT_APPLIED = "robot.not_applied"


@dataclass(frozen=True)
class Target:
    study_id: int
    session_id: int
    interaction_id: int
    position: int
    booth: str
    condition: str
    face: str


def target_of(db: Session, session_id: int) -> Target:
    try:
        view = repository.load_session(db, session_id)
    except repository.SessionNotFoundError as exc:
        raise NotFoundError(str(exc)) from None
    interaction = view.current
    if interaction is None or view.session.state == "complete":
        raise ConflictError("There is no interaction to set the robot up for.")
    return Target(view.session.study_id, session_id, interaction.id, interaction.position,
                  view.session.booth, interaction.condition, interaction.face)  # fmt: skip


def _result(outcome: Outcome) -> dict[str, Any]:
    return {"sent": outcome.sent, "reason": outcome.reason, "detail": outcome.detail}


def record(db: Session, target: Target, behaviour: Outcome, face: Outcome) -> Event:
    return events.record(
        db,
        APPLIED if behaviour.sent and face.sent else NOT_APPLIED,
        source="wizard",
        study_id=target.study_id,
        session_id=target.session_id,
        interaction_id=target.interaction_id,
        payload={
            "position": target.position,
            "condition": target.condition,
            "face": target.face,
            "behaviour": _result(behaviour),
            "face_result": _result(face),
        },
    )


async def apply(state: Any, session_id: int) -> dict[str, Any]:
    target = await run_in_threadpool(read, state, target_of, session_id)
    bridge = worker_link.bridge_of(state)
    params = (getattr(state, "behaviour_params", None) or {}).get(target.condition)
    body: dict[str, Any] = {"name": target.condition}
    if params:
        body["params"] = dict(params)
    behaviour = await worker_link.send_command(bridge, target.booth, SET_BEHAVIOUR, body)
    face = await worker_link.send_command(bridge, target.booth, SET_FACE, {"face_id": target.face})
    event = await run_in_threadpool(write, state, record, target, behaviour, face)
    return {"event_id": event.id, "kind": event.kind, **event.payload}
