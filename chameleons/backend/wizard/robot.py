"""Put the robot in the interaction's condition and face: ``set_behaviour`` and ``set_face``
to the booth's worker, both logged (``robot.applied`` or ``robot.not_applied``).

The server's booth flow (:mod:`chameleons.backend.booth`) calls :func:`apply_with` when an
interaction starts and after a condition switch, sending only what the worker has not
acknowledged already; the wizard can send it again by hand (:func:`apply`, always sent and
logged). The console used to call it after a start or switch too, and every set-up was
logged twice. The behaviour and its
parameters are the study's for the condition
(:func:`chameleons.backend.booth.behaviour.robot_behaviour`); for ``natural`` also the
recording it replays (clip, yoked or synthetic), logged with the set-up.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from chameleons.backend.booth.behaviour import behaviour_words, robot_behaviour
from chameleons.backend.events import repository as events
from chameleons.backend.models import Event, Interaction, Study
from chameleons.backend.studies.errors import ConflictError, NotFoundError
from chameleons.backend.studies.specs import spec_of
from chameleons.backend.wizard import repository, worker_link
from chameleons.backend.wizard.playback import write
from chameleons.backend.wizard.service import Outcome
from chameleons.worker.control import FURHAT_RENDERER, RETRY_ROBOT, SET_BEHAVIOUR, SET_FACE

APPLIED = "robot.applied"
NOT_APPLIED = "robot.not_applied"
RETRY = "robot.retry_requested"


@dataclass(frozen=True)
class Target:
    study_id: int
    session_id: int
    interaction_id: int
    position: int
    booth: str
    condition: str
    face: str
    behaviour: str = ""
    params: dict[str, Any] | None = None
    natural_source: dict[str, Any] | None = None
    renderer: str | None = None  # the condition's robot (2d/3d/furhat); None: the booth's
    words: str = ""  # the behaviour and its parameters in words (behaviour_words)

    def face_body(self) -> dict[str, Any]:
        body: dict[str, Any] = {"face_id": self.face}
        if self.renderer:
            body["renderer"] = self.renderer
        return body

    def behaviour_body(self) -> dict[str, Any]:
        body: dict[str, Any] = {"name": self.behaviour or self.condition}
        if self.params:
            body["params"] = dict(self.params)
        return body


Finder = Callable[[Session], Target]


def _session_view(db: Session, session_id: int) -> repository.SessionView:
    try:
        return repository.load_session(db, session_id)
    except repository.SessionNotFoundError as exc:
        raise NotFoundError(str(exc)) from None


def target_of(db: Session, session_id: int) -> Target:
    view = _session_view(db, session_id)
    interaction = view.current
    if interaction is None or view.session.state in ("complete", "ended"):
        raise ConflictError("There is no interaction to set the robot up for.")
    return Target(view.session.study_id, session_id, interaction.id, interaction.position,
                  view.session.booth, interaction.condition, interaction.face)  # fmt: skip


def prepared(db: Session, state: Any, find: Finder) -> Target:
    """The target with the study's behaviour for its condition (choosing what ``natural``
    replays once per interaction) and the display face the condition names, which the
    interaction records."""
    target = find(db)
    chosen = robot_behaviour(db, state, target.interaction_id, target.condition)
    renderer = condition_renderer(db, target.study_id, target.condition)
    interaction = db.get(Interaction, target.interaction_id)
    if interaction is not None and interaction.renderer != renderer:
        interaction.renderer = renderer
    if interaction is not None and interaction.behaviour_params != chosen.params:
        interaction.behaviour_params = dict(chosen.params)
        mirror = getattr(getattr(state, "settings", None), "mirror", None)
        interaction.behaviour_words = behaviour_words(chosen, mirror)[:512]
    return replace(
        target,
        behaviour=chosen.name,
        params=chosen.params,
        natural_source=chosen.natural_source,
        renderer=renderer,
        words=interaction.behaviour_words or "" if interaction is not None else "",
    )


def condition_renderer(db: Session, study_id: int, condition: str) -> str | None:
    """The robot the study's condition names (the display's 2d or 3d face, or furhat), if
    any."""
    study = db.get(Study, study_id)
    if study is None:
        return None
    spec = spec_of(study)
    return next((c.renderer for c in spec.conditions if c.id == condition), None)


def robots_needed(db: Session, study_id: int | None) -> dict[str, list[str]]:
    """Which robot of a booth with both (``virtual+furhat``) runs each of the study's
    conditions: ``furhat`` those whose renderer is furhat, ``display`` all others (2d, 3d,
    or none: the worker's switch drives the display then). Only robots with conditions."""
    study = db.get(Study, study_id) if study_id is not None else None
    if study is None:
        return {}
    needs: dict[str, list[str]] = {}
    for condition in spec_of(study).conditions:
        robot = FURHAT_RENDERER if condition.renderer == FURHAT_RENDERER else "display"
        needs.setdefault(robot, []).append(condition.id)
    return needs


def _result(outcome: Outcome) -> dict[str, Any]:
    result = {"sent": outcome.sent, "reason": outcome.reason, "detail": outcome.detail}
    if _unchanged(outcome):
        result["unchanged"] = True
    return result


def record(
    db: Session, target: Target, behaviour: Outcome, face: Outcome, source: str = "wizard"
) -> Event:
    payload: dict[str, Any] = {
        "position": target.position,
        "condition": target.condition,
        "behaviour_name": target.behaviour,
        "face": target.face,
        "renderer": target.renderer,
        "behaviour": _result(behaviour),
        "face_result": _result(face),
    }
    if target.params:
        payload["params"] = dict(target.params)
    if target.words:
        payload["behaviour_words"] = target.words
    head = (behaviour.result or {}).get("head")
    if isinstance(head, dict):  # how the worker processes the copied head (re-centring)
        payload["head"] = head
    if target.natural_source is not None:
        payload["natural_source"] = dict(target.natural_source)
    return events.record(
        db,
        APPLIED if behaviour.sent and face.sent else NOT_APPLIED,
        source=source,
        study_id=target.study_id,
        session_id=target.session_id,
        interaction_id=target.interaction_id,
        payload=payload,
    )


async def apply(state: Any, session_id: int) -> dict[str, Any]:
    """The console's set-up of the session's current interaction (always sent and logged)."""
    result = await apply_with(state, partial(target_of, session_id=session_id))
    assert result is not None  # without only_changes every command is sent
    return result


async def apply_with(
    state: Any, find: Finder, *, source: str = "wizard", only_changes: bool = False,
    log_unchanged: bool = False,
) -> dict[str, Any] | None:  # fmt: skip
    """Set up the robot for the target ``find`` picks; with ``only_changes`` a command whose
    body the booth's worker has acknowledged already is not sent again (it would restart a
    ``natural`` clip), and when nothing needed sending nothing is logged (None) unless
    ``log_unchanged`` (an interaction's start: its timeline says what the robot runs, even
    when the last interaction left it so; the results say ``unchanged``)."""
    target = await run_in_threadpool(write, state, prepared, state, find)
    bridge = worker_link.bridge_of(state)
    behaviour = await _send(bridge, target.booth, SET_BEHAVIOUR, target.behaviour_body(),
                            only_changes)  # fmt: skip
    face = await _send(bridge, target.booth, SET_FACE, target.face_body(), only_changes)
    if _unchanged(behaviour) and _unchanged(face) and not log_unchanged:
        return None
    event = await run_in_threadpool(write, state, record, target, behaviour, face, source)
    return {"event_id": event.id, "kind": event.kind, **event.payload}


async def retry(state: Any, session_id: int) -> dict[str, Any]:
    """The wizard asks the worker to try the robot again (after a refused or unanswered
    login the driver waits for this); logged as ``robot.retry_requested``."""
    view = await run_in_threadpool(write, state, _session_view, session_id)
    booth, current = view.session.booth, view.current
    outcome = await worker_link.send_command(worker_link.bridge_of(state), booth,
                                             RETRY_ROBOT, {})  # fmt: skip

    def log(db: Session) -> Event:
        return events.record(db, RETRY, source="wizard", study_id=view.session.study_id,
                             session_id=session_id,
                             interaction_id=current.id if current else None,
                             payload={"booth": booth, **_result(outcome)})  # fmt: skip

    event = await run_in_threadpool(write, state, log)
    return {"event_id": event.id, **_result(outcome)}


def _unchanged(outcome: Outcome) -> bool:
    return bool(outcome.result and outcome.result.get("unchanged"))


async def _send(
    bridge: Any | None, booth: str, command: str, body: dict[str, Any], only_changes: bool
) -> Outcome:
    if only_changes and acknowledged(bridge, booth, command) == body:
        return Outcome(True, result={"unchanged": True})
    return await worker_link.send_command(bridge, booth, command, body)


def acknowledged(bridge: Any | None, booth: str, command: str) -> dict[str, Any] | None:
    """What the bridge last had acknowledged for this command on this booth."""
    reader = getattr(bridge, "state", None)
    if not callable(reader):
        return None
    state = reader(booth)
    value = state.behaviour if command == SET_BEHAVIOUR else state.face
    return value if isinstance(value, dict) else None
