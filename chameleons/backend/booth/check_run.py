"""The booth check's head movement and copy step, run for real on the booth's worker.

Between participants the worker idles in whatever it ran last (``still`` at start), so the
check itself puts the robot into ``copy`` with the study's configured delay, asks the
technician to hold still facing the robot, then to turn the head left and to nod (the page
and ``chameleons booth-check`` show the prompts of :meth:`Plan.prompts`), waits for the
robot's copy of the movement, and restores the behaviour that ran before: always, also when
a step fails or the request is cancelled.

When the "hold still" is over the worker is told to take the resting pose (the mean of that
time, ``mark_head_rest``): the movement is judged from it, not from zero (a phone below the
face rests at +15 degrees of pitch, which is no nod), and the copied head is re-centred on
it (``recentre_head``); at the end the neutral is measured afresh from the next frames, so
a participant is never copied on the technician's pose. The copy-delay probe is reset when
the rest is taken, so the measured delay is the delay of this movement only. A simulated
face (the demo's: ``state.face_cues``) is told each move as it is asked for, so it does it.

- The condition is the study's: the one the technician picks (``?condition=``, any of the
  study's ``copy`` conditions), else with a session its study's first ``copy`` condition
  still to come in the session's plan (else the study's first ``copy`` condition); without
  a session, the study of the booth's latest session (else the latest active study). The
  robot runs that condition's full parameters (channels, gain, mirror, delay distribution,
  coexpress, intermittent, only); a condition that draws at random gets the seed the
  wizard path gives it (its ``seed``, else the id of the session's interaction in that
  condition, else 0). A study without a ``copy`` condition is checked with the worker's
  default delay, and the step says so.
- The condition's ``renderer`` picks the robot on a booth with both (``virtual+furhat``):
  the check runs on it and puts the booth back afterwards (:mod:`.check_robot`).
- The check is refused while a participant's interaction runs on the booth (it would
  take the robot from the participant), and while another check runs on it. Should an
  interaction start during the check, the robot is given that interaction's set-up at the
  end instead of the behaviour from before.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import AsyncIterator, Mapping
from dataclasses import dataclass, field
from functools import partial
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession
from starlette.concurrency import run_in_threadpool

from chameleons.backend.booth import check_copy
from chameleons.backend.booth.behaviour import RobotBehaviour, behaviour_words
from chameleons.backend.booth.check import Movement
from chameleons.backend.booth.flows import running_slot, running_target
from chameleons.backend.models import Interaction, Study
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.studies.specs import spec_of
from chameleons.backend.wizard import robot, worker_link
from chameleons.backend.wizard.playback import read
from chameleons.worker.behaviours.copy import DEFAULT_DELAY
from chameleons.worker.behaviours.copy_params import needs_seed, nominal_delay
from chameleons.worker.control import (
    MARK_HEAD_REST,
    RECENTRE_HEAD,
    RESET_DELAY_PROBE,
    SET_BEHAVIOUR,
)

COPY = "copy"
STILL = "still"  # a worker's start behaviour when its hello does not say
HEARTBEAT_S = 1.0  # the worker's heartbeat; its probe also measures once a second
COPY_MARGIN_S = 2.5  # after the copy: the probe's next measurement and the heartbeat after it
LATE_COPY_S = 4.0  # a measurement late on a busy booth PC is waited for this much longer
POLL_S = 0.1


class CheckRefusedError(Exception):
    """The check cannot run now (a participant's interaction, another check); a sentence."""


@dataclass(frozen=True)
class Plan:
    """The head movement's timing and the copy condition the check runs the robot with."""

    turn_s: float
    nod_s: float
    delay_s: float  # the condition's delay as one number (a distribution's mean)
    condition: str | None  # the study's copy condition (None: the worker's default delay)
    study_id: int | None
    rest_s: float = 2.0
    params: dict[str, Any] = field(default_factory=dict)  # sent to the worker
    words: str = ""  # the params in words (the export's behaviour_words)
    choices: tuple[tuple[str, str], ...] = ()  # the study's copy conditions and their words
    flip: bool = False  # the condition's mirror differs from the booth's: the yaw is negated
    renderer: str | None = None  # the condition's robot (2d, 3d, furhat; None: the booth's)
    face: str | None = None  # the face to set with it when the booth has none acknowledged

    @property
    def movement_s(self) -> float:
        return self.turn_s + self.nod_s

    @property
    def latest_s(self) -> float:
        """The longest the condition may copy late (a distribution's upper end)."""
        return check_copy.delay_range(self.params)[1] if self.params else self.delay_s

    def prompts(self) -> list[dict[str, Any]]:
        """What the technician is asked to do, in order, and for how long (seconds)."""
        brows = bool(self.params) and check_copy.separates_brows(self.params)
        nod = "Nod (chin down and up)" + (", then raise your eyebrows" if brows else "")
        low, high = check_copy.delay_range(self.params or {"delay": self.delay_s})
        late = f"{low:g} s later" if low == high else f"{low:g}-{high:g} s later"
        return [
            {"id": "rest", "text": "Face the robot and hold still", "seconds": self.rest_s},
            {"id": "turn", "text": "Turn your head left (and back)", "seconds": self.turn_s},
            {"id": "nod", "text": nod, "seconds": self.nod_s},
            {"id": "copy", "seconds": self.latest_s + COPY_MARGIN_S,
             "text": f"Hold still: the robot copies you {late}"},
        ]  # fmt: skip

    def describe(self) -> dict[str, Any]:
        return {"copy_delay_s": self.delay_s, "copy_condition": self.condition,
                "copy_params": self.params, "behaviour_words": self.words,
                "conditions": [{"id": c, "words": w} for c, w in self.choices],
                "renderer": self.renderer, "study_id": self.study_id,
                "prompts": self.prompts()}  # fmt: skip

    def movement(self, **seen: Any) -> Movement:
        return Movement(self.delay_s, self.condition, params=self.params or None,
                        words=self.words, flip=self.flip, **seen)  # fmt: skip


def plan_for(
    db: DbSession, booth: str, session: SessionRow | None, settings: Any,
    condition: str | None = None,
) -> Plan:  # fmt: skip
    """The check's plan; ``condition`` picks one of the study's ``copy`` conditions (default:
    the first still to come in the session, else the study's first). ValueError (a
    sentence) for a condition the study has not or that is not a copy."""
    study, condition_ids = _study_and_order(db, booth, session)
    timing = (float(settings.booth_check_turn_seconds), float(settings.booth_check_nod_seconds))
    rest = float(settings.booth_check_rest_seconds)
    conditions = ({c.id: c for c in spec_of(study).conditions if c.behaviour == COPY}
                  if study is not None else {})  # fmt: skip
    if condition is not None and condition not in conditions:
        names = ", ".join(conditions) or "none"
        raise ValueError(f"{condition!r} is not a copy condition of this study (its copy "
                         f"conditions: {names}).")  # fmt: skip
    mirror = getattr(settings, "mirror", None)
    choices = tuple((c, _words(conditions[c].params, mirror)) for c in conditions)
    order = [c for c in condition_ids if c in conditions] + list(conditions)
    chosen = condition or (order[0] if order else None)
    if study is None or chosen is None:
        return Plan(*timing, DEFAULT_DELAY, None, study.id if study else None, rest,
                    choices=choices)  # fmt: skip
    params = dict(conditions[chosen].params)
    if needs_seed(params) and params.get("seed") is None:  # the wizard path's rule
        params["seed"] = _interaction_seed(db, session, chosen)
    flip = params.get("mirror") is not None and params["mirror"] != (mirror is not False)
    return Plan(*timing, nominal_delay(params), chosen, study.id, rest, params,
                _words(params, mirror), choices, flip, conditions[chosen].renderer,
                _face(db, study, session, chosen))  # fmt: skip


def _face(db: DbSession, study: Study, session: SessionRow | None, condition: str) -> str | None:
    """The face of the session's interaction in ``condition`` (else the study's first): set
    with the condition's robot when the booth has no face acknowledged yet."""
    if session is not None:
        found = db.scalars(select(Interaction.face).where(
            Interaction.session_id == session.id, Interaction.condition == condition
        ).order_by(Interaction.position).limit(1)).first()  # fmt: skip
        if found:
            return str(found)
    faces = spec_of(study).faces
    return faces[0].id if faces else None


def _words(params: dict[str, Any], mirror: bool | None) -> str:
    return behaviour_words(RobotBehaviour(COPY, dict(params)), mirror)


def _interaction_seed(db: DbSession, session: SessionRow | None, condition: str) -> int:
    """The seed the participant's interaction in ``condition`` will draw with (its id, as
    the wizard path sets it), so the check runs the same draws; 0 without one."""
    if session is None:
        return 0
    found = db.scalars(select(Interaction.id).where(Interaction.session_id == session.id,
                                                    Interaction.condition == condition)
                       .order_by(Interaction.position).limit(1)).first()  # fmt: skip
    return int(found) if found is not None else 0


def _study_and_order(
    db: DbSession, booth: str, session: SessionRow | None
) -> tuple[Study | None, list[str]]:
    """The study whose delay applies, and the session's conditions still to come."""
    if session is None:
        session = db.scalars(select(SessionRow).where(SessionRow.booth == booth)
                             .order_by(SessionRow.created_at.desc(), SessionRow.id.desc())
                             .limit(1)).first()  # fmt: skip
    if session is None:
        latest = select(Study).where(Study.is_active.is_(True))
        return db.scalars(latest.order_by(Study.created_at.desc(), Study.id.desc())).first(), []
    to_come = select(Interaction.condition).where(
        Interaction.session_id == session.id, Interaction.state != "done"
    )
    return db.get(Study, session.study_id), list(db.scalars(to_come.order_by(Interaction.position)))


def refusal(db: DbSession, booth: str) -> str | None:
    """Why the check must not run on ``booth`` now (None: it may)."""
    slot = running_slot(db, booth)
    if slot is None:
        return None
    return (f"Interaction {slot.position} of session {slot.session_id} is running on {booth}: "
            "the booth check would take the robot from the participant. Run it before the "
            "session starts or between participants.")  # fmt: skip


@contextlib.asynccontextmanager
async def exclusive(state: Any, booth: str) -> AsyncIterator[None]:
    """One check at a time per booth (two would fight over the robot's behaviour)."""
    running: set[str] | None = getattr(state, "booth_checks_running", None)
    if running is None:
        running = state.booth_checks_running = set()
    if booth in running:
        raise CheckRefusedError(f"A booth check is already running on {booth}.")
    running.add(booth)
    try:
        yield
    finally:
        running.discard(booth)


async def exercise(
    state: Any, booth: str, plan: Plan, telemetry: Mapping[str, Any], robot_words: str = ""
) -> Movement:
    """Run the robot in ``copy`` for the head movement and its copy; the behaviour from
    before is restored whatever happens (shielded: a cancelled request restores too).
    ``robot_words``: the robot it runs on (:mod:`.check_robot`), for the result."""
    bridge = worker_link.bridge_of(state)
    previous = _running_behaviour(bridge, booth, telemetry)
    params = plan.params or {"delay": plan.delay_s}
    body = {"name": COPY, "params": params}
    switched = await worker_link.send_command(bridge, booth, SET_BEHAVIOUR, body)
    movement = plan.movement(robot=robot_words)
    try:
        if not switched.sent:
            return plan.movement(problem=switched.detail, robot=robot_words)
        _cue(state, booth, "rest", plan.rest_s)
        await asyncio.sleep(plan.rest_s)
        rest = {"rest_seconds": plan.rest_s}
        await worker_link.send_command(bridge, booth, MARK_HEAD_REST, rest)
        await worker_link.send_command(bridge, booth, RECENTRE_HEAD, {"seconds": plan.rest_s})
        await worker_link.send_command(bridge, booth, RESET_DELAY_PROBE, {})
        started = time.monotonic()
        _cue(state, booth, "turn", plan.turn_s)
        await asyncio.sleep(max(0.0, started + plan.turn_s - time.monotonic()))
        _cue(state, booth, "nod", plan.nod_s)
        head = await _heartbeat_after(bridge, booth, started + plan.movement_s)
        _cue(state, booth, "copy", plan.latest_s + COPY_MARGIN_S)
        copy = await _copy_measured(bridge, booth, started + plan.movement_s + plan.latest_s)
        movement = plan.movement(head=head, copy=copy, robot=robot_words)
    finally:
        await asyncio.shield(_restore(state, booth, previous))
    return movement


def _cue(state: Any, booth: str, move: str, seconds: float) -> None:
    """Tell a simulated face on ``booth`` what the check asks for now (the demo's face
    simulator follows it); nothing without one."""
    cues = getattr(state, "face_cues", None)
    if callable(cues):
        cues(booth, move, seconds)


def _running_behaviour(
    bridge: Any | None, booth: str, telemetry: Mapping[str, Any]
) -> dict[str, Any] | None:
    """What the worker runs now (its heartbeat), else what it last acknowledged, else what it
    started with (its hello). A heartbeat sent before the worker's behaviour stage first
    reported names none, and with nothing set through the server yet the check restored
    nothing: the robot went on copying the participant after the check."""
    name, params = telemetry.get("behaviour"), telemetry.get("behaviour_params")
    if isinstance(name, str) and name:
        return {"name": name, **({"params": dict(params)} if isinstance(params, Mapping)
                                 and params else {})}  # fmt: skip
    acknowledged = robot.acknowledged(bridge, booth, SET_BEHAVIOUR)
    return acknowledged if acknowledged is not None else {"name": _started_with(bridge, booth)}


def _started_with(bridge: Any | None, booth: str) -> str:
    """The behaviour the booth's worker started in (its hello), ``still`` when unknown."""
    workers = getattr(bridge, "workers", None)
    info = workers().get(booth) if callable(workers) else None
    name = (getattr(info, "hello", None) or {}).get("behaviour")
    return name if isinstance(name, str) and name else STILL


async def _restore(state: Any, booth: str, previous: dict[str, Any] | None) -> None:
    # The copied head was re-centred on the technician's rest: measure the neutral afresh
    # from the next frames (a participant between interactions is not copied on the
    # technician's pose; a session start re-measures it anyway).
    await worker_link.send_command(worker_link.bridge_of(state), booth, RECENTRE_HEAD, {})
    if await set_up_started_interaction(state, booth):
        return
    if previous is not None:
        bridge = worker_link.bridge_of(state)
        await worker_link.send_command(bridge, booth, SET_BEHAVIOUR, previous)


async def set_up_started_interaction(state: Any, booth: str) -> bool:
    """If an interaction started on ``booth`` during the check, give the robot its set-up
    (behaviour and face, what differs from what the worker has) and say so (True)."""
    slot = await run_in_threadpool(read, state, running_slot, booth)
    if slot is None:
        return False
    find = partial(running_target, interaction_id=slot.interaction_id)
    with contextlib.suppress(Exception):
        await robot.apply_with(state, find, source="server", only_changes=True)
    return True


def _heartbeat(bridge: Any | None, booth: str) -> tuple[dict[str, Any] | None, float]:
    """The latest heartbeat and when it arrived (monotonic; -inf: none)."""
    telemetry, age = worker_link.latest_telemetry(bridge, booth)
    return telemetry, (time.monotonic() - age) if age is not None else float("-inf")


async def _heartbeat_after(bridge: Any | None, booth: str, moment: float) -> dict[str, Any] | None:
    """The first heartbeat that arrived after ``moment`` (it covers the second before)."""
    await asyncio.sleep(max(0.0, moment - time.monotonic()))
    deadline = moment + 3 * HEARTBEAT_S
    while True:
        telemetry, arrived = _heartbeat(bridge, booth)
        if arrived > moment or time.monotonic() > deadline:
            return telemetry
        await asyncio.sleep(POLL_S)


async def _copy_measured(bridge: Any | None, booth: str, copied: float) -> dict[str, Any] | None:
    """A heartbeat from after the robot's copy, with a measured delay when one comes."""
    telemetry = await _heartbeat_after(bridge, booth, copied + COPY_MARGIN_S - HEARTBEAT_S)
    deadline = time.monotonic() + LATE_COPY_S
    while not (telemetry or {}).get("movement_delay") and time.monotonic() < deadline:
        await asyncio.sleep(POLL_S)
        telemetry = _heartbeat(bridge, booth)[0]
    return telemetry
