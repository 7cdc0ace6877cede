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
  becomes ``robot.head_neutral`` of the session running on that booth;
- a booth's worker connecting (``worker_connected``, ``worker_restarted``) while an
  interaction runs there: whatever the worker has not acknowledged of that interaction's
  set-up and recording is sent now (an interaction started before the worker came up would
  otherwise run unset and unrecorded). The bridge's own replay after a restart re-sends only
  what was acknowledged before it, so the two complement each other.

Nothing here runs inside a request: the hub's listener only queues a job. Jobs run on the
event loop in order per session (and per booth for outages); database work goes to the
thread pool. A missing or silent worker never raises: it is logged (``robot.not_applied``,
``recording.not_started``, ``recording.not_stopped``) with the reason.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import deque
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any, TypeVar

from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from chameleons.backend.booth import repository, service
from chameleons.backend.events import repository as events
from chameleons.backend.events.unit_of_work import write_session
from chameleons.backend.sessions.ending import ENDED_EARLY
from chameleons.backend.studies.errors import ConflictError, NotFoundError
from chameleons.backend.synchrony.runner import SynchronyRunner
from chameleons.backend.synchrony.service import params_from
from chameleons.backend.wizard import capture, robot, worker_link
from chameleons.backend.wizard.service import Outcome
from chameleons.worker.control import START_RECORDING, STOP_RECORDING
from chameleons.worker.envelope import Message
from chameleons.worker.recording import write_problem

log = logging.getLogger(__name__)
T = TypeVar("T")
Job = Callable[[], Awaitable[None]]
SOURCE = "server"
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
RECORDING_FAILED = "recording.failed"
HEAD_NEUTRAL = "robot.head_neutral"
SESSION_STARTED = "session.started"


@dataclass(frozen=True)
class Slot:
    """Where an interaction runs."""

    study_id: int
    session_id: int
    interaction_id: int
    position: int
    booth: str
    running: bool


def slot_of(db: Session, interaction_id: int) -> Slot | None:
    located = repository.locate(db, interaction_id)
    if located is None:
        return None
    s, i = located.session, located.interaction
    return Slot(s.study_id, s.id, i.id, i.position, s.booth, located.running)


def running_slot(db: Session, booth: str) -> Slot | None:
    """The interaction running on ``booth`` now, if any."""
    session = repository.active_session(db, booth)
    interaction = repository.running_interaction(db, session) if session else None
    return slot_of(db, interaction.id) if interaction is not None else None


def running_target(db: Session, interaction_id: int) -> robot.Target:
    """The robot set-up of this interaction, while it runs (else a conflict: skip it)."""
    located = repository.locate(db, interaction_id)
    if located is None or not located.running:
        raise ConflictError(f"Interaction {interaction_id} is not running.")
    s, i = located.session, located.interaction
    return robot.Target(s.study_id, s.id, i.id, i.position, s.booth, i.condition, i.face)


class BoothFlow:
    def __init__(self, state: Any) -> None:
        self.state = state
        self._lanes: dict[str, deque[Job]] = {}
        self._tasks: dict[str, asyncio.Task[None]] = {}
        self._remove_listener: Callable[[], None] | None = None
        self._stopped = False
        self._robot_kinds: dict[str, str] = {}  # booth -> last robot.* kind logged
        settings = getattr(state, "settings", None)
        self.synchrony: SynchronyRunner | None = None
        if settings is not None and settings.sync_enabled:
            self.synchrony = SynchronyRunner(state.sessionmaker, Path(settings.data_dir),
                                             params_from(settings))  # fmt: skip

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
        self._stopped = True
        tasks = list(self._tasks.values())
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        if self.synchrony is not None:
            await self.synchrony.stop(self.state.settings.sync_drain_s)

    async def settled(self) -> None:
        """Wait until every queued job has run (tests, shutdown)."""
        while self._tasks:
            await asyncio.gather(*list(self._tasks.values()), return_exceptions=True)

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
            self._enqueue(lane, partial(self._interaction_done, interaction_id))

    def _on_worker(self, message: Message) -> None:
        kind = WORKER_KINDS.get(message.type)
        booth = message.topic.partition(".")[2]
        if kind is not None:
            body = message.body
            payload = {"booth": booth, **{k: body.get(k) for k in SUMMARY_FIELDS}}
            self._enqueue(f"booth:{booth}", partial(self._log_outage, booth, kind, payload, None))
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
                              partial(self._log_outage, booth, kind, payload, when))  # fmt: skip
        elif message.type == "recording_stopped":
            self._enqueue(f"booth:{booth}", partial(self._route_reported, dict(body)))
        elif message.type == "recording_failed":
            self._enqueue(f"booth:{booth}", partial(self._route_failed, dict(body)))
        elif message.type == "head_neutral":  # the copied head's new neutral pose
            payload = {"booth": booth, **{k: v for k, v in body.items() if k != "wall_time"}}
            when = body.get("worker_time")
            when = float(when) if isinstance(when, int | float) else None
            job = partial(self._log_outage, booth, HEAD_NEUTRAL, payload, when)
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
            self._enqueue(f"booth:{booth}", partial(self._log_outage, booth, kind, payload, None))

    # --- lanes ---------------------------------------------------------------------------------
    def _enqueue(self, key: str, job: Job) -> None:
        if self._stopped:
            return
        lane = self._lanes.get(key)
        if lane is None:
            lane = self._lanes[key] = deque()
            self._tasks[key] = asyncio.create_task(self._drain(key, lane))
        lane.append(job)

    async def _drain(self, key: str, lane: deque[Job]) -> None:
        try:
            while lane:
                job = lane.popleft()
                try:
                    await job()
                except Exception:  # one failed reaction must not stop the others
                    log.exception("booth flow job on %s failed", key)
        finally:
            # No await between the empty check and here: nothing can be queued meanwhile.
            if self._lanes.get(key) is lane:
                del self._lanes[key]
                del self._tasks[key]

    # --- database helpers ----------------------------------------------------------------------
    def _read(self, work: Callable[..., T], *args: Any) -> Awaitable[T]:
        def run() -> T:
            db: Session = self.state.sessionmaker()
            try:
                return work(db, *args)
            finally:
                db.close()

        return run_in_threadpool(run)

    def _write(self, work: Callable[..., T], *args: Any) -> Awaitable[T]:
        def run() -> T:
            with write_session(self.state.sessionmaker, self.state.live_hub) as db:
                return work(db, *args)

        return run_in_threadpool(run)

    def _log(self, slot: Slot, kind: str, payload: dict[str, Any]) -> Awaitable[Any]:
        return self._write(
            lambda db: events.record(
                db, kind, source=SOURCE, study_id=slot.study_id, session_id=slot.session_id,
                interaction_id=slot.interaction_id, payload={"position": slot.position, **payload},
            )
        )  # fmt: skip

    # --- jobs ----------------------------------------------------------------------------------
    async def _interaction_started(self, interaction_id: int) -> None:
        """Recording starts (the robot is set up in its own lane, see _on_committed)."""
        slot = await self._read(slot_of, interaction_id)
        if slot is None or not slot.running:
            return
        if service.config_of(self.state).record:
            await self._start_recording(slot)

    async def _route_catch_up(self, booth: str) -> None:
        """A worker connected: catch up the interaction running on its booth, in that
        interaction's own lane (after a start still being handled there)."""
        slot = await self._read(running_slot, booth)
        if slot is not None:
            self._enqueue(f"session:{slot.session_id}", partial(self._catch_up, slot))

    async def _catch_up(self, slot: Slot) -> None:
        current = await self._read(slot_of, slot.interaction_id)
        if current is None or not current.running:
            return
        await self._set_up_robot(slot.interaction_id)  # only what is not acknowledged
        record = service.config_of(self.state).record
        if record and not self._recording_acknowledged(slot.booth, slot.interaction_id):
            await self._start_recording(current)

    async def _set_up_robot(self, interaction_id: int, log_unchanged: bool = False) -> None:
        find = partial(running_target, interaction_id=interaction_id)
        with contextlib.suppress(ConflictError, NotFoundError):  # over already: nothing to do
            await robot.apply_with(self.state, find, source=SOURCE, only_changes=True,
                                   log_unchanged=log_unchanged)  # fmt: skip

    async def _start_recording(self, slot: Slot) -> None:
        directory = self._directory(slot)
        body = {"interaction_id": slot.interaction_id, "directory": str(directory)}
        outcome = await self._command(slot.booth, START_RECORDING, body)
        if outcome.sent:
            files = (outcome.result or {}).get("files", {})
            payload = {"directory": str(directory), "files": files}
            await self._log(slot, repository.RECORDING_STARTED, payload)
        else:
            await self._log(slot, "recording.not_started", _why(outcome))

    async def _interaction_done(self, interaction_id: int) -> None:
        slot = await self._read(slot_of, interaction_id)
        if slot is None or not service.config_of(self.state).record:
            return
        body = {"interaction_id": interaction_id}
        outcome = await self._command(slot.booth, STOP_RECORDING, body)
        directory = self._directory(slot)
        if outcome.sent:
            rows = await self._index(slot, outcome.result, directory)
            kind, payload = "recording.stopped", {"recordings": rows}
        else:
            # A worker that is gone cannot be writing: its journals are safe to recover now;
            # one that is only slow reports the files itself when it closes them.
            gone = not self._worker_connected(slot.booth)
            rows = await self._index(slot, None, directory) if gone else []
            kind, payload = "recording.not_stopped", {**_why(outcome), "recordings": rows}
        started: bool = await self._read(repository.recording_started, interaction_id)
        if rows or started:
            await self._log(slot, kind, payload)
        if rows:
            self._synchronise(interaction_id)

    async def _route_reported(self, body: dict[str, Any]) -> None:
        """A ``recording_stopped`` event: index its files in the interaction's own lane."""
        try:
            interaction_id = int(body.get("interaction_id"))  # type: ignore[arg-type]
        except (TypeError, ValueError):
            return
        slot = await self._read(slot_of, interaction_id)
        if slot is not None:
            job = partial(self._index_reported, slot, body)
            self._enqueue(f"session:{slot.session_id}", job)

    async def _route_failed(self, body: dict[str, Any]) -> None:
        try:
            interaction_id = int(body.get("interaction_id"))  # type: ignore[arg-type]
        except (TypeError, ValueError):
            return
        slot = await self._read(slot_of, interaction_id)
        if slot is not None:
            reason = str(body.get("reason") or "The recording could not be written.")
            job = partial(
                self._log,
                slot,
                RECORDING_FAILED,
                {"reason": reason, "stream": body.get("stream"), "source": "worker"},
            )
            self._enqueue(f"session:{slot.session_id}", job)

    async def _index_reported(self, slot: Slot, body: dict[str, Any]) -> None:
        rows = await self._index(slot, body, None)
        if rows:
            await self._log(slot, "recording.indexed", {"recordings": rows})
            self._synchronise(slot.interaction_id)

    def _synchronise(self, interaction_id: int) -> None:
        """Queue the synchrony of an interaction whose recordings were just indexed."""
        if self.synchrony is not None and not self._stopped:
            self.synchrony.submit(interaction_id)

    async def _index(
        self, slot: Slot, reported: dict[str, Any] | None, scan: Path | None
    ) -> list[dict[str, Any]]:
        data_dir = service.data_dir_of(self.state)
        problems: list[str] = []

        def work(db: Session) -> list[dict[str, Any]]:
            added = service.index_recordings(
                db, slot.interaction_id, data_dir, reported, scan, problems
            )
            return service.describe(added)

        try:
            rows = await self._write(work)
        except OSError as exc:  # e.g. an unreadable folder: report it, never crash the job
            rows = []
            problems.append(write_problem(exc, scan or data_dir))
        for problem in problems:
            await self._log(slot, RECORDING_FAILED, {"reason": problem, "source": "server"})
        return rows

    async def _log_outage(
        self, booth: str, kind: str, payload: dict[str, Any], worker_time: float | None
    ) -> None:
        def work(db: Session) -> None:
            session = repository.active_session(db, booth)
            if session is None:
                return  # nobody is in the booth: nothing to flag
            interaction = repository.running_interaction(db, session)
            events.record(
                db, kind, source="bridge", study_id=session.study_id, session_id=session.id,
                interaction_id=interaction.id if interaction else None,
                payload={"position": interaction.position if interaction else None, **payload},
                worker_time=worker_time,
            )  # fmt: skip

        await self._write(work)

    # --- the worker ----------------------------------------------------------------------------
    def _directory(self, slot: Slot) -> Path:
        data_dir = service.data_dir_of(self.state)
        return service.recording_directory(data_dir, slot.study_id, slot.session_id)

    async def _command(self, booth: str, command: str, body: dict[str, Any]) -> Outcome:
        bridge = worker_link.bridge_of(self.state)
        return await worker_link.send_command(bridge, booth, command, body)

    def _recording_acknowledged(self, booth: str, interaction_id: int) -> bool:
        """Whether the worker acknowledged recording this interaction (the bridge's state)."""
        reader = getattr(worker_link.bridge_of(self.state), "state", None)
        if not callable(reader):
            return False
        recording = reader(booth).recording
        return isinstance(recording, dict) and recording.get("interaction_id") == interaction_id

    def _worker_connected(self, booth: str) -> bool:
        bridge = worker_link.bridge_of(self.state)
        workers = getattr(bridge, "workers", None)
        if not callable(workers):
            return False
        info = workers().get(booth)
        return bool(info is not None and info.connected(getattr(bridge, "stale_after", 3.0)))


def _why(outcome: Outcome) -> dict[str, Any]:
    return {"reason": outcome.reason, "detail": outcome.detail}
