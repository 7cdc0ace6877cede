"""The booth follows the session on its own: server-side reactions to committed events.

- ``interaction.advanced`` to ``discussion`` (the interaction starts): the robot is set to
  the interaction's condition and face (:func:`chameleons.backend.wizard.robot.apply_with`,
  sending only what the worker has not acknowledged already; logged once either way: the
  console sends nothing of its own then), and the worker starts recording it;
- ``condition.switched`` on a running interaction: the robot is set up again;
- ``interaction.advanced`` to ``done``, or ``session.ended_early`` while it ran: the
  recording stops and its files are indexed as
  Recording rows (from the worker's answer, plus a scan of the directory that recovers crash
  journals); a ``recording_stopped`` event from the worker (e.g. the recorder closing on a
  clean worker stop) is indexed too;
- a recording the disk refuses (read-only folder, full disk: the worker's
  ``recording_failed`` event, or an ``OSError`` while indexing) is logged as
  ``recording.failed`` with one sentence of reason, once per interaction and cause; the
  dashboard flags it and the export carries it (``interactions.recording_problem``);
- the bridge's ``worker.<booth>`` messages and the driver's robot-state events become
  ``worker.lost`` / ``worker.restarted`` / ``worker.connected`` / ``robot.disconnected`` /
  ``robot.connected`` events of the session running on that booth, so the dashboard's
  outage flags see them;
- once an interaction's recordings are indexed, its synchrony (issue 32) is queued on the
  synchrony runner's own thread (:mod:`chameleons.backend.synchrony.runner`);
- ``session.started``: the booth's face capture is told to pair with the next phone that
  sends (``capture.pairing_reset``, :mod:`chameleons.backend.wizard.capture`);
- the worker's ``head_neutral`` event (the neutral pose the copied head is re-centred on)
  becomes ``robot.head_neutral`` of the session running on that booth, and its
  ``copy_draw`` events (a bout or jittered delay that ``copy`` drew and began to show)
  ``robot.copy_draw`` of the interaction running there (the export summarises them);
- a booth's worker connecting (``worker_connected``, ``worker_restarted``) while an
  interaction runs there: whatever the worker has not acknowledged of that interaction's
  set-up and recording is sent now (an interaction started before the worker came up would
  otherwise run unset and unrecorded). The bridge's own replay after a restart re-sends only
  what was acknowledged before it, so the two complement each other.

Nothing here runs inside a request: the hub's listener only queues a job. Jobs run on the
event loop in order per session (and per booth for outages); database work goes to the
thread pool. A missing or silent worker never raises: it is logged (``robot.not_applied``,
``recording.not_started``, ``recording.not_stopped``) with the reason.

Parts: where an interaction runs (``slots``), the lanes jobs run in (``lanes``), the
database work off the loop (``flow_db``) and the recordings (``recording_flow``); here the
listeners and the robot's set-up.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

from chameleons.backend.booth import service
from chameleons.backend.booth.flow_db import SOURCE, FlowDb
from chameleons.backend.booth.lanes import Job, Lanes
from chameleons.backend.booth.recording_flow import RECORDING_FAILED, RecordingFlow
from chameleons.backend.booth.slots import Slot, running_slot, running_target, slot_of
from chameleons.backend.sessions.ending import ENDED_EARLY
from chameleons.backend.studies.errors import ConflictError, NotFoundError
from chameleons.backend.synchrony.runner import SynchronyRunner
from chameleons.backend.synchrony.service import params_from
from chameleons.backend.wizard import capture, robot
from chameleons.worker.envelope import Message

__all__ = [
    "RECORDING_FAILED",
    "SOURCE",
    "BoothFlow",
    "Job",
    "Slot",
    "running_slot",
    "running_target",
    "slot_of",
]

CATCH_UP_KINDS = frozenset({"worker_connected", "worker_restarted"})
WORKER_KINDS = {
    "worker_lost": "worker.lost",
    "worker_restarted": "worker.restarted",
    "worker_connected": "worker.connected",
}
SUMMARY_FIELDS = ("instance", "restarts", "last_seen_s")
ROBOT_KINDS = {"disconnected": "robot.disconnected", "closed": "robot.disconnected",
               "connected": "robot.connected", "auth_refused": "robot.auth_refused",
               "auth_timeout": "robot.auth_timeout"}  # fmt: skip
AUTH_STATES = frozenset({"auth_refused", "auth_timeout"})
# Robot states the heartbeat repeats into events when the one-off robot_state event was lost
# (sent before the server's subscription took: ZeroMQ drops a PUB's messages until then).
HEARTBEAT_STATES = AUTH_STATES | {"connected"}
HEAD_NEUTRAL = "robot.head_neutral"
COPY_DRAW = "robot.copy_draw"
LOGGED_WORKER_EVENTS = {"head_neutral": HEAD_NEUTRAL, "copy_draw": COPY_DRAW}
SESSION_STARTED = "session.started"


class BoothFlow:
    def __init__(self, state: Any) -> None:
        self.state = state
        self._lanes = Lanes()
        self._db = FlowDb(state)
        self._remove_listener: Callable[[], None] | None = None
        self._robot_kinds: dict[str, str] = {}  # booth -> last robot.* kind logged
        settings = getattr(state, "settings", None)
        self.synchrony: SynchronyRunner | None = None
        if settings is not None and settings.sync_enabled:
            self.synchrony = SynchronyRunner(state.sessionmaker, Path(settings.data_dir),
                                             params_from(settings))  # fmt: skip
        self._recordings = RecordingFlow(state, self._db, self._lanes, self.synchrony)
        self._enqueue = self._lanes.enqueue

    # --- lifecycle -------------------------------------------------------------------------
    def start(self, bridge: Any | None = None) -> BoothFlow:
        """Listen to committed events (and to ``bridge``); call from the running loop."""
        self._remove_listener = self.state.live_hub.add_listener(self._on_committed)
        if bridge is not None:
            bridge.add_listener("worker.", self._on_worker)
            bridge.add_listener("event.", self._on_worker_event)
            bridge.add_listener("telemetry.", self._on_telemetry)
        return self

    async def stop(self, drain_seconds: float = 0.0) -> None:
        """Stop listening; with ``drain_seconds``, let queued jobs finish that long first."""
        if self._remove_listener is not None:
            self._remove_listener()
        if drain_seconds > 0:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self.settled(), drain_seconds)
        await self._lanes.close()
        if self.synchrony is not None:
            await self.synchrony.stop(self.state.settings.sync_drain_s)

    async def settled(self) -> None:
        """Wait until every queued job has run (tests, shutdown)."""
        await self._lanes.settled()

    # --- listeners (on the loop; they only queue) --------------------------------------------
    def _on_committed(self, _channel: str, message: dict[str, Any]) -> None:
        event = message.get("event") if message.get("type") == "event" else None
        if isinstance(event, dict) and event.get("kind") == SESSION_STARTED:
            # A new participant: the booth's capture pairs with the next phone that sends.
            session_id = int(event["session_id"])
            job = partial(capture.reset_pairing, self.state, session_id, SOURCE, log_unsent=False)
            self._enqueue(f"session:{session_id}", job)  # type: ignore[arg-type]
        if not isinstance(event, dict) or event.get("interaction_id") is None:
            return
        interaction_id, kind = int(event["interaction_id"]), event.get("kind")
        step = (event.get("payload") or {}).get("to")
        lane = f"session:{event.get('session_id')}"
        # The robot's set-up has a lane of its own: queued behind a finished interaction's
        # recording (stopped and indexed in the session's lane) it came late, once after the
        # next interaction was over (a fast rehearsal), and that one ran unset.
        robot_lane = f"robot:{event.get('session_id')}"
        if kind == "interaction.advanced" and step == "discussion":
            # Logged even when the worker runs it already (the last interaction left it so):
            # the interaction's one "Robot set to" line (the console sends none of its own).
            self._enqueue(robot_lane, partial(self._set_up_robot, interaction_id, True))
            self._enqueue(lane, partial(self._interaction_started, interaction_id))
        elif kind == "condition.switched":
            self._enqueue(robot_lane, partial(self._set_up_robot, interaction_id))
        elif (kind == "interaction.advanced" and step == "done") or kind == ENDED_EARLY:
            self._enqueue(lane, partial(self._recordings.interaction_done, interaction_id))

    def _on_worker(self, message: Message) -> None:
        kind = WORKER_KINDS.get(message.type)
        booth = message.topic.partition(".")[2]
        if kind is not None:
            body = message.body
            payload = {"booth": booth, **{k: body.get(k) for k in SUMMARY_FIELDS}}
            job = partial(self._db.log_outage, booth, kind, payload, None)
            self._enqueue(f"booth:{booth}", job)
        if message.type in CATCH_UP_KINDS:
            self._enqueue(f"booth:{booth}", partial(self._route_catch_up, booth))

    def _on_worker_event(self, message: Message) -> None:
        booth = message.topic.partition(".")[2]
        body = message.body
        if message.type == "robot_state":
            kind = ROBOT_KINDS.get(str(body.get("state")))
            # A robot that stays away is retried with backoff: log the change, not each retry.
            if kind is not None and self._robot_kinds.get(booth) != kind:
                self._robot_kinds[booth] = kind
                payload = {"booth": booth, **{k: v for k, v in body.items() if k != "wall_time"}}
                worker_time = body.get("worker_time")
                when = float(worker_time) if isinstance(worker_time, int | float) else None
                self._enqueue(f"booth:{booth}",
                              partial(self._db.log_outage, booth, kind, payload, when))  # fmt: skip
        elif message.type == "recording_stopped":
            self._enqueue(f"booth:{booth}", partial(self._recordings.route_reported, dict(body)))
        elif message.type == "recording_failed":
            self._enqueue(f"booth:{booth}", partial(self._recordings.route_failed, dict(body)))
        elif message.type in LOGGED_WORKER_EVENTS:  # a new neutral head pose; a random draw
            payload = {"booth": booth, **{k: v for k, v in body.items() if k != "wall_time"}}
            when = body.get("worker_time")
            when = float(when) if isinstance(when, int | float) else None
            kind = LOGGED_WORKER_EVENTS[message.type]
            job = partial(self._db.log_outage, booth, kind, payload, when)
            self._enqueue(f"booth:{booth}", job)

    def _on_telemetry(self, message: Message) -> None:
        """A refused login or a connection is reported once, possibly before the server's
        subscription took: the 1 Hz heartbeat repeats the robot's state, so it is never
        lost (a robot seen connected only here is logged as ``robot.connected``)."""
        booth = message.topic.partition(".")[2]
        state = str(message.body.get("robot_state"))
        kind = ROBOT_KINDS.get(state) if state in HEARTBEAT_STATES else None
        if kind is not None and self._robot_kinds.get(booth) != kind:
            self._robot_kinds[booth] = kind
            payload = {"booth": booth, "state": state, "reason": message.body.get("robot_problem")}
            job = partial(self._db.log_outage, booth, kind, payload, None)
            self._enqueue(f"booth:{booth}", job)

    # --- jobs ----------------------------------------------------------------------------------
    async def _interaction_started(self, interaction_id: int) -> None:
        """Recording starts (the robot is set up in its own lane, see _on_committed)."""
        slot = await self._db.read(slot_of, interaction_id)
        if slot is None or not slot.running:
            return
        if service.config_of(self.state).record:
            await self._recordings.start(slot)

    async def _route_catch_up(self, booth: str) -> None:
        """A worker connected: catch up the interaction running on its booth, in that
        interaction's own lane (after a start still being handled there)."""
        slot = await self._db.read(running_slot, booth)
        if slot is not None:
            self._enqueue(f"session:{slot.session_id}", partial(self._catch_up, slot))

    async def _catch_up(self, slot: Slot) -> None:
        current = await self._db.read(slot_of, slot.interaction_id)
        if current is None or not current.running:
            return
        await self._set_up_robot(slot.interaction_id)  # only what is not acknowledged
        record = service.config_of(self.state).record
        if record and not self._recordings.acknowledged(slot.booth, slot.interaction_id):
            await self._recordings.start(current)

    async def _set_up_robot(self, interaction_id: int, log_unchanged: bool = False) -> None:
        find = partial(running_target, interaction_id=interaction_id)
        with contextlib.suppress(ConflictError, NotFoundError):  # over already: nothing to do
            await robot.apply_with(self.state, find, source=SOURCE, only_changes=True,
                                   log_unchanged=log_unchanged)  # fmt: skip
