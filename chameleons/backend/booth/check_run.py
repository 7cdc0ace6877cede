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

- The delay is the study's: with a session, its study's first ``copy`` condition still to
  come in the session's plan (else the study's first ``copy`` condition); without one, the
  study of the booth's latest session (else the latest active study). A study without a
  ``copy`` condition is checked with the worker's default delay, and the step says so.
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
from dataclasses import dataclass
from functools import partial
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession
from starlette.concurrency import run_in_threadpool

from chameleons.backend.booth.check import Movement
from chameleons.backend.booth.flows import running_slot, running_target
from chameleons.backend.models import Interaction, Study
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.studies.specs import spec_of
from chameleons.backend.wizard import robot, worker_link
from chameleons.backend.wizard.playback import read
from chameleons.worker.behaviours.copy import DEFAULT_DELAY
from chameleons.worker.behaviours.copy_params import nominal_delay
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
    """The head movement's timing and the copy delay the check runs the robot with."""

    turn_s: float
    nod_s: float
    delay_s: float
    condition: str | None  # the study's copy condition (None: the worker's default delay)
    study_id: int | None
    rest_s: float = 2.0

    @property
    def movement_s(self) -> float:
        return self.turn_s + self.nod_s

    def prompts(self) -> list[dict[str, Any]]:
        """What the technician is asked to do, in order, and for how long (seconds)."""
        return [
            {"id": "rest", "text": "Face the robot and hold still", "seconds": self.rest_s},
            {"id": "turn", "text": "Turn your head left (and back)", "seconds": self.turn_s},
            {"id": "nod", "text": "Nod (chin down and up)", "seconds": self.nod_s},
            {"id": "copy", "seconds": self.delay_s + COPY_MARGIN_S,
             "text": f"Hold still: the robot copies you {self.delay_s:g} s later"},
        ]  # fmt: skip

    def describe(self) -> dict[str, Any]:
        return {"copy_delay_s": self.delay_s, "copy_condition": self.condition,
                "study_id": self.study_id, "prompts": self.prompts()}  # fmt: skip


def plan_for(db: DbSession, booth: str, session: SessionRow | None, settings: Any) -> Plan:
    study, condition_ids = _study_and_order(db, booth, session)
    delay, condition = DEFAULT_DELAY, None
    if study is not None:
        conditions = {c.id: c for c in spec_of(study).conditions if c.behaviour == COPY}
        order = [c for c in condition_ids if c in conditions] + list(conditions)
        if order:
            condition = order[0]
            delay = nominal_delay(conditions[condition].params)  # a distribution's mean
    return Plan(float(settings.booth_check_turn_seconds), float(settings.booth_check_nod_seconds),
                delay, condition, study.id if study else None,
                float(settings.booth_check_rest_seconds))  # fmt: skip


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


async def exercise(state: Any, booth: str, plan: Plan, telemetry: Mapping[str, Any]) -> Movement:
    """Run the robot in ``copy`` for the head movement and its copy; the behaviour from
    before is restored whatever happens (shielded: a cancelled request restores too)."""
    bridge = worker_link.bridge_of(state)
    previous = _running_behaviour(bridge, booth, telemetry)
    body = {"name": COPY, "params": {"delay": plan.delay_s}}
    switched = await worker_link.send_command(bridge, booth, SET_BEHAVIOUR, body)
    movement = Movement(plan.delay_s, plan.condition)
    try:
        if not switched.sent:
            return Movement(plan.delay_s, plan.condition, problem=switched.detail)
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
        _cue(state, booth, "copy", plan.delay_s + COPY_MARGIN_S)
        copy = await _copy_measured(bridge, booth, started + plan.movement_s + plan.delay_s)
        movement = Movement(plan.delay_s, plan.condition, head=head, copy=copy)
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
    slot = await run_in_threadpool(read, state, running_slot, booth)
    if slot is not None:  # an interaction started meanwhile: its set-up, not the old one
        find = partial(running_target, interaction_id=slot.interaction_id)
        with contextlib.suppress(Exception):
            await robot.apply_with(state, find, source="server", only_changes=True)
        return
    if previous is not None:
        bridge = worker_link.bridge_of(state)
        await worker_link.send_command(bridge, booth, SET_BEHAVIOUR, previous)


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
