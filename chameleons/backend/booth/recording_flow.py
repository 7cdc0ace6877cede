"""The booth flow's recordings: the worker starts recording an interaction when it starts
and stops when it is done; the files are indexed as Recording rows (from the worker's
answer, plus a scan of the directory that recovers crash journals), and their synchrony is
queued. A recording the disk refuses is logged as ``recording.failed`` with one sentence of
reason; a missing or silent worker as ``recording.not_started`` / ``recording.not_stopped``.
"""

from __future__ import annotations

from functools import partial
from pathlib import Path
from typing import Any

from sqlalchemy.orm import Session

from chameleons.backend.booth import repository, service
from chameleons.backend.booth.flow_db import FlowDb
from chameleons.backend.booth.lanes import Lanes
from chameleons.backend.booth.slots import Slot, slot_of
from chameleons.backend.synchrony.runner import SynchronyRunner
from chameleons.backend.wizard import worker_link
from chameleons.backend.wizard.service import Outcome
from chameleons.worker.control import START_RECORDING, STOP_RECORDING
from chameleons.worker.recording import write_problem

RECORDING_FAILED = "recording.failed"


class RecordingFlow:
    def __init__(
        self, state: Any, db: FlowDb, lanes: Lanes, synchrony: SynchronyRunner | None
    ) -> None:
        self.state = state
        self.db = db
        self.lanes = lanes
        self.synchrony = synchrony

    async def start(self, slot: Slot) -> None:
        directory = self._directory(slot)
        body = {"interaction_id": slot.interaction_id, "directory": str(directory)}
        outcome = await self._command(slot.booth, START_RECORDING, body)
        if outcome.sent:
            files = (outcome.result or {}).get("files", {})
            payload = {"directory": str(directory), "files": files}
            await self.db.log(slot, repository.RECORDING_STARTED, payload)
        else:
            await self.db.log(slot, "recording.not_started", _why(outcome))

    async def interaction_done(self, interaction_id: int) -> None:
        slot = await self.db.read(slot_of, interaction_id)
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
        started: bool = await self.db.read(repository.recording_started, interaction_id)
        if rows or started:
            await self.db.log(slot, kind, payload)
        if rows:
            self._synchronise(interaction_id)

    async def route_reported(self, body: dict[str, Any]) -> None:
        """A ``recording_stopped`` event: index its files in the interaction's own lane."""
        try:
            interaction_id = int(body.get("interaction_id"))  # type: ignore[arg-type]
        except (TypeError, ValueError):
            return
        slot = await self.db.read(slot_of, interaction_id)
        if slot is not None:
            job = partial(self._index_reported, slot, body)
            self.lanes.enqueue(f"session:{slot.session_id}", job)

    async def route_failed(self, body: dict[str, Any]) -> None:
        try:
            interaction_id = int(body.get("interaction_id"))  # type: ignore[arg-type]
        except (TypeError, ValueError):
            return
        slot = await self.db.read(slot_of, interaction_id)
        if slot is not None:
            reason = str(body.get("reason") or "The recording could not be written.")
            job = partial(
                self.db.log,
                slot,
                RECORDING_FAILED,
                {"reason": reason, "stream": body.get("stream"), "source": "worker"},
            )
            self.lanes.enqueue(f"session:{slot.session_id}", job)

    def acknowledged(self, booth: str, interaction_id: int) -> bool:
        """Whether the worker acknowledged recording this interaction (the bridge's state)."""
        reader = getattr(worker_link.bridge_of(self.state), "state", None)
        if not callable(reader):
            return False
        recording = reader(booth).recording
        return isinstance(recording, dict) and recording.get("interaction_id") == interaction_id

    async def _index_reported(self, slot: Slot, body: dict[str, Any]) -> None:
        rows = await self._index(slot, body, None)
        if rows:
            await self.db.log(slot, "recording.indexed", {"recordings": rows})
            self._synchronise(slot.interaction_id)

    def _synchronise(self, interaction_id: int) -> None:
        """Queue the synchrony of an interaction whose recordings were just indexed."""
        if self.synchrony is not None and not self.lanes.stopped:
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
            rows = await self.db.write(work)
        except OSError as exc:  # e.g. an unreadable folder: report it, never crash the job
            rows = []
            problems.append(write_problem(exc, scan or data_dir))
        for problem in problems:
            await self.db.log(slot, RECORDING_FAILED, {"reason": problem, "source": "server"})
        return rows

    # --- the worker ----------------------------------------------------------------------------
    def _directory(self, slot: Slot) -> Path:
        data_dir = service.data_dir_of(self.state)
        return service.recording_directory(data_dir, slot.study_id, slot.session_id)

    async def _command(self, booth: str, command: str, body: dict[str, Any]) -> Outcome:
        bridge = worker_link.bridge_of(self.state)
        return await worker_link.send_command(bridge, booth, command, body)

    def _worker_connected(self, booth: str) -> bool:
        bridge = worker_link.bridge_of(self.state)
        workers = getattr(bridge, "workers", None)
        if not callable(workers):
            return False
        info = workers().get(booth)
        return bool(info is not None and info.connected(getattr(bridge, "stale_after", 3.0)))


def _why(outcome: Outcome) -> dict[str, Any]:
    return {"reason": outcome.reason, "detail": outcome.detail}
