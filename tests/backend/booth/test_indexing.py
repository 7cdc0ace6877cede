"""Indexing the worker's files as Recording rows (real Parquet files and crash journals), and
the live hub's after-commit listener the booth flow reacts through."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session, sessionmaker

from chameleons.backend.booth import service
from chameleons.backend.events import repository as events
from chameleons.backend.events.hub import LiveHub
from chameleons.backend.events.unit_of_work import write_session
from chameleons.backend.models import Recording
from chameleons.worker.frames import N_BLENDSHAPES, FaceFrame
from chameleons.worker.recording import FrameRecorder, journal_path
from tests.backend.booth.conftest import new_session
from tests.support.bots import StaffApi


def frame(i: int) -> FaceFrame:
    shapes = np.full(N_BLENDSHAPES, 0.01 * (i % 50), dtype=np.float32)
    return FaceFrame.from_vector(np.concatenate([shapes, np.zeros(9, np.float32)]),
                                 i / 60, i / 60, "participant")  # fmt: skip


def write_recording(path: Path, frames: int) -> None:
    with FrameRecorder(path, chunk_frames=16) as recorder:
        for i in range(frames):
            recorder.write(frame(i))


def leave_crash_journal(path: Path, frames: int, scratch: Path) -> None:
    """What a worker that died mid-recording leaves: the journal of its flushed chunks."""
    with FrameRecorder(scratch / path.name, chunk_frames=16, chunk_seconds=1e6) as recorder:
        for i in range(frames):
            recorder.write(frame(i))
        path.parent.mkdir(parents=True, exist_ok=True)
        journal_path(path).write_bytes(recorder.journal.read_bytes())


@pytest.fixture
def interaction(app: FastAPI, pi: StaffApi, study_id: int) -> int:
    from tests.backend.booth.test_flow_with_worker import interaction_id

    wizard, _ = new_session(pi, study_id)
    return interaction_id(app, wizard)


def test_a_crash_journal_is_recovered_and_indexed_once(
    app: FastAPI, interaction: int, tmp_path: Path
) -> None:
    data_dir = Path(app.state.settings.data_dir)
    directory = service.recording_directory(data_dir, 1, 1)
    closed = directory / f"interaction-{interaction}-agent.parquet"
    crashed = directory / f"interaction-{interaction}-participant.parquet"
    write_recording(closed, 40)
    leave_crash_journal(crashed, 40, tmp_path)  # only the 32 frames of two full chunks
    write_recording(directory / "interaction-999999-participant.parquet", 5)  # not ours
    factory: sessionmaker[Session] = app.state.sessionmaker

    with write_session(factory, app.state.live_hub) as db:
        rows = service.describe(service.index_recordings(db, interaction, data_dir, scan=directory))
    assert {(r["stream"], r["frames"]) for r in rows} == {("agent", 40), ("participant", 32)}
    assert crashed.is_file()
    assert not journal_path(crashed).exists()
    assert all(r["path"].startswith("recordings/study-1/session-1/") for r in rows)
    assert all(r["size_bytes"] == (data_dir / r["path"]).stat().st_size for r in rows)

    reported = {"files": {"participant": str(crashed)}, "frames": {"participant": 32}}
    with write_session(factory, app.state.live_hub) as db:
        again = service.index_recordings(db, interaction, data_dir, reported, directory)
    assert again == []


def test_a_file_the_server_cannot_see_is_indexed_from_the_worker_s_report(
    app: FastAPI, interaction: int
) -> None:
    data_dir = Path(app.state.settings.data_dir)
    # A remote worker writes where the server told it (the server's recording folder) on a
    # disk the server may not share: the file is not there for the server.
    directory = service.recording_directory(data_dir, 1, 1)
    remote = directory / f"interaction-{interaction}-participant.parquet"
    reported = {"files": {"participant": str(remote), "agent": "/x/y.parquet.journal"},
                "frames": {"participant": 1234}}  # fmt: skip
    with write_session(app.state.sessionmaker, app.state.live_hub) as db:
        rows = service.index_recordings(db, interaction, data_dir, reported)
        stored = str(remote.relative_to(data_dir.resolve()))
        assert [(r.stream, r.path, r.frames, r.size_bytes) for r in rows] == [
            ("participant", stored, 1234, 0)
        ]  # a journal (the worker failed to close it) is not a recording to index
        assert db.query(Recording).count() == 1


def test_withdrawal_deletes_what_the_flow_indexed(
    app: FastAPI, client: TestClient, pi: StaffApi, study_id: int
) -> None:
    from tests.backend.booth.test_flow_with_worker import interaction_id

    wizard, _ = new_session(pi, study_id)
    interaction = interaction_id(app, wizard)
    data_dir = Path(app.state.settings.data_dir)
    directory = service.recording_directory(data_dir, study_id, wizard.session_id)
    write_recording(directory / f"interaction-{interaction}-participant.parquet", 20)
    with write_session(app.state.sessionmaker, app.state.live_hub) as db:
        assert len(service.index_recordings(db, interaction, data_dir, scan=directory)) == 1
    code = wizard.snapshot["participant"]["code"]
    result = pi.post(f"/api/pi/participants/{code}/withdraw?study={study_id}", {"confirm": code})
    assert result["files_deleted"] == 1
    assert not directory.exists()  # emptied directories go too


def test_the_hub_tells_listeners_about_committed_events_only(
    app: FastAPI, client: TestClient, interaction: int
) -> None:
    hub: LiveHub = app.state.live_hub
    seen: list[dict[str, Any]] = []

    def broken(_channel: str, _message: dict[str, Any]) -> None:
        raise RuntimeError("a listener's bug")

    assert client.portal is not None
    remove_broken = client.portal.call(hub.add_listener, broken)
    remove = client.portal.call(hub.add_listener, lambda _c, m: seen.append(m["event"]))
    factory = app.state.sessionmaker

    def log(db: Session, kind: str) -> None:
        events.record(db, kind, source="test", session_id=1, interaction_id=interaction)

    def log_then_fail() -> None:
        with write_session(factory, hub) as db:
            log(db, "rolled.back")
            raise RuntimeError("abort")

    with pytest.raises(RuntimeError, match="abort"):
        log_then_fail()
    with write_session(factory, hub) as db:
        log(db, "committed")
    client.portal.call(asyncio.sleep, 0)  # let the loop run the delivery it was handed
    assert [event["kind"] for event in seen] == ["committed"]
    remove()
    remove_broken()
    with write_session(factory, hub) as db:
        log(db, "after.removal")
    client.portal.call(asyncio.sleep, 0)
    assert [event["kind"] for event in seen] == ["committed"]
