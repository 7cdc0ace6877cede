"""A forged "recording stopped" on the plain worker link (the loopback default: any local
process can publish to it) never gets a file outside ``<data dir>/recordings`` indexed,
whatever path it names (elsewhere, ``..`` out of the folder, a symlink inside pointing out,
another interaction's name); and a withdrawal never deletes such a file, even when an older
version indexed it. Before, the file was indexed and the next withdrawal deleted it."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from sqlalchemy import select

from chameleons.backend.booth import service
from chameleons.backend.bridge import Bridge
from chameleons.backend.models import Interaction, Recording
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.withdrawal.files import recording_file
from chameleons.worker.envelope import Message, serialize
from tests.backend.booth.conftest import BOOTH, new_session, timeline, until
from tests.backend.booth.test_indexing import write_recording
from tests.backend.booth.test_zmq_curve import inject
from tests.support.bots import StaffApi, WizardBot

pytestmark = pytest.mark.usefixtures("flow")


def _interaction(app: FastAPI, wizard: WizardBot) -> tuple[int, Path]:
    """Interaction 1's id and the folder the server has its recordings written to."""
    with app.state.sessionmaker() as db:
        session = db.get(SessionRow, wizard.session_id)
        assert session is not None
        interaction = db.scalars(
            select(Interaction.id).where(
                Interaction.session_id == session.id, Interaction.position == 1
            )
        ).one()
        folder = service.recording_directory(
            Path(app.state.settings.data_dir), session.study_id, session.id
        )
    return int(interaction), folder


def _forged(interaction: int, path: Path) -> list[bytes]:
    body = {"interaction_id": interaction, "files": {"participant": str(path)},
            "frames": {"participant": 100}}  # fmt: skip
    return serialize(Message(f"event.{BOOTH}", "recording_stopped", 1, "recorder",
                             time.monotonic(), body))  # fmt: skip


def _indexed(app: FastAPI) -> set[Path]:
    """The files the index names, resolved."""
    data_dir = Path(app.state.settings.data_dir)
    with app.state.sessionmaker() as db:
        return {recording_file(data_dir, p).resolve() for p in db.scalars(select(Recording.path))}


def _refusals(wizard: WizardBot) -> list[str]:
    return [str(e["payload"].get("reason")) for e in timeline(wizard)
            if e["kind"] == "recording.failed"]  # fmt: skip


def _handled(app: FastAPI, wizard: WizardBot, path: Path) -> Callable[[], bool]:
    """Whether the server has dealt with the message naming ``path``: refused or indexed."""
    return lambda: any(str(path) in r for r in _refusals(wizard)) or (
        path.resolve() in _indexed(app)
    )


def _escapes(interaction: int, folder: Path, tmp_path: Path) -> list[Path]:
    """Real recordings where none may be indexed from, each named as the worker names one."""
    name = f"interaction-{interaction}-participant.parquet"
    elsewhere = tmp_path / "elsewhere" / name
    write_recording(elsewhere, 10)
    data_dir = folder.parents[2]
    beside = data_dir / name  # in the data folder, not in its recordings
    write_recording(beside, 10)
    linked = folder / "linked"  # a folder inside that is a symlink to one outside
    folder.mkdir(parents=True, exist_ok=True)
    linked.symlink_to(elsewhere.parent, target_is_directory=True)
    other = folder / f"interaction-{interaction + 1000}-participant.parquet"
    write_recording(other, 10)  # inside, but another interaction's file
    return [elsewhere, folder / ".." / ".." / ".." / name, linked / name, other]


def test_a_forged_recording_stopped_gets_nothing_outside_the_recordings_indexed(
    app: FastAPI, pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    wizard.start()
    interaction, folder = _interaction(app, wizard)
    escapes = _escapes(interaction, folder, tmp_path)
    for path in escapes:  # published as any local process can, until the server dealt with it
        inject(bridge.telemetry_endpoint, _forged(interaction, path),
               _handled(app, wizard, path), seconds=30)  # fmt: skip
        until(_handled(app, wizard, path), what=f"the message naming {path}")
    assert _indexed(app) == set()
    reasons = _refusals(wizard)
    for path in escapes:
        assert any(str(path) in r and "not indexed" in r for r in reasons), (path, reasons)
    assert all(path.is_file() for path in escapes)


def test_a_withdrawal_deletes_nothing_an_older_index_named_outside_the_recordings(
    app: FastAPI, pi: StaffApi, study_id: int, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    wizard.start()
    interaction, folder = _interaction(app, wizard)
    escapes = _escapes(interaction, folder, tmp_path)[:3]  # the other interaction's is inside
    genuine = folder / f"interaction-{interaction}-agent.parquet"
    write_recording(genuine, 10)
    with app.state.sessionmaker() as db:  # as an index written before the check would hold
        for path in [*escapes, genuine]:
            stream = "agent" if path == genuine else "participant"
            db.add(Recording(interaction_id=interaction, stream=stream, path=str(path),
                             frames=10, size_bytes=path.stat().st_size))  # fmt: skip
        db.commit()
    rows = _rows(app)
    for path, row in rows.items():  # nor can the PI download one
        expected = 200 if path == genuine else 404
        assert pi.http.get(f"/pi/recordings/{row}").status_code == expected, path
    code = wizard.snapshot["participant"]["code"]
    result: dict[str, Any] = pi.post(f"/api/pi/participants/{code}/withdraw?study={study_id}",
                                     {"confirm": code})  # fmt: skip
    assert all(path.is_file() for path in escapes), "a file outside the recordings went"
    assert not genuine.exists()  # the participant's own recording did go
    assert result["files_deleted"] == 1
    [outside] = [s for s in result["not_removed"] if "outside the data folder" in s]
    assert outside.startswith("3 files the index named outside the data folder's recordings")
    assert all(str(path) in outside for path in escapes)


def _rows(app: FastAPI) -> dict[Path, int]:
    with app.state.sessionmaker() as db:
        return {Path(r.path): r.id for r in db.scalars(select(Recording))}
