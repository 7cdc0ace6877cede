"""Face source as data: the participant's recording names the capture source of most of its
frames (read from the file the worker wrote), the interaction takes it over, and the export
carries it (with its codebook entry) so the analysis can split by it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from fastapi import FastAPI
from sqlalchemy.orm import Session, sessionmaker

from chameleons.backend.booth import service
from chameleons.backend.events.unit_of_work import write_session
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.models import Interaction
from chameleons.worker.frames import N_BLENDSHAPES, FaceFrame
from chameleons.worker.recording import FrameRecorder
from tests.backend.booth.test_indexing import interaction as interaction
from tests.backend.export.test_export import read_csv


def write_frames(path: Path, sources: list[tuple[str, str]]) -> None:
    with FrameRecorder(path, chunk_frames=16) as recorder:
        for i, (source, calibration) in enumerate(sources):
            values = np.zeros(N_BLENDSHAPES + 9, dtype=np.float32)
            frame = FaceFrame.from_vector(values, i / 30, i / 30, source)
            frame.calibration = calibration
            recorder.write(frame)


def test_the_participants_face_source_is_recorded_and_exported(
    app: FastAPI, interaction: int, tmp_path: Path
) -> None:
    data_dir = Path(app.state.settings.data_dir)
    directory = service.recording_directory(data_dir, 1, 1)
    # The page was calibrated after a few frames; a phone that sent for a moment is outvoted.
    sources = ([("webcam-browser", "geometric")] * 5 + [("webcam-browser", "neutral")] * 30
               + [("livelink", "")] * 4)  # fmt: skip
    write_frames(directory / f"interaction-{interaction}-participant.parquet", sources)
    write_frames(directory / f"interaction-{interaction}-agent.parquet", [("agent", "")] * 10)
    factory: sessionmaker[Session] = app.state.sessionmaker
    with write_session(factory, app.state.live_hub) as db:
        rows = service.index_recordings(db, interaction, data_dir, scan=directory)
        found = {r.stream: (r.face_source, r.face_calibration) for r in rows}
    assert found == {"participant": ("webcam-browser", "neutral"), "agent": (None, None)}
    with factory() as db:
        row = db.get(Interaction, interaction)
        assert row is not None
        assert (row.face_source, row.face_calibration) == ("webcam-browser", "neutral")
        export_to_directory(db, ExportRequest(formats=("csv",)), tmp_path / "export")
    _, exported = read_csv(tmp_path / "export" / "interactions.csv")
    mine = [r for r in exported if r["face_source"]]
    assert [(r["face_source"], r["face_calibration"]) for r in mine] == [
        ("webcam-browser", "neutral")
    ]
    codebook = (tmp_path / "export" / "codebook.csv").read_text("utf-8")
    assert "livelink, facecapturex, webcam-browser, webcam-python" in codebook
    assert "neutral+iphone:<hash>" in codebook


def test_an_iphone_recording_has_no_calibration(app: FastAPI, interaction: int) -> None:
    data_dir = Path(app.state.settings.data_dir)
    directory = service.recording_directory(data_dir, 1, 1)
    write_frames(directory / f"interaction-{interaction}-participant.parquet",
                 [("livelink", "")] * 20)  # fmt: skip
    factory: sessionmaker[Session] = app.state.sessionmaker
    with write_session(factory, app.state.live_hub) as db:
        (row,) = service.index_recordings(db, interaction, data_dir, scan=directory)
        assert (row.face_source, row.face_calibration) == ("livelink", None)
