"""``CHAMELEONS_LSL=1``: the server publishes every committed timeline event of a booth's
session as a marker on ``chameleons-<booth>-events``; a real LSL inlet on this machine
reads them, stamped with the events' times on LSL's clock, free text left out."""

from __future__ import annotations

import json
import uuid
from pathlib import Path

import pyarrow.parquet as pq
import pylsl
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.app import create_app
from chameleons.backend.db import build_sessionmaker
from chameleons.backend.events import repository as events
from chameleons.backend.events.unit_of_work import write_session
from chameleons.backend.instruments.markers import MarkerPublisher
from chameleons.backend.instruments.xdf_import import import_xdf
from chameleons.backend.models import Event, Session
from chameleons.instruments.lsl import parse_marker
from chameleons.settings import Settings
from chameleons.worker.envelope import Message
from tests.instruments.lsl_inlets import open_inlet, pull_until, resolve
from tests.instruments.xdf_session import epoch
from tests.instruments.xdf_writer import XdfStream, write_xdf
from tests.support.factories import populate


@pytest.mark.slow
def test_committed_events_become_markers_of_their_booth(
    settings: Settings, db_session: DbSession
) -> None:
    booth = f"lsl-{uuid.uuid4().hex[:6]}"
    study = populate(db_session, participants=1)
    session = db_session.get(Session, study.session_ids[0])
    assert session is not None
    session.booth = booth
    db_session.commit()
    app = create_app(settings.model_copy(update={"lsl": True}))
    with TestClient(app):
        inlet = open_inlet(resolve(f"chameleons-{booth}-events"))  # opened at start
        info = inlet.info()
        before = pylsl.local_clock()
        ids = []
        with write_session(app.state.sessionmaker, app.state.live_hub) as db:
            for kind, payload in (("session.paused", {"reason": "break"}),
                                  ("wizard.note", {"text": "P looked away"})):  # fmt: skip
                ids.append(events.record(db, kind, source="wizard", study_id=study.study_id,
                                         session_id=session.id, payload=payload).id)  # fmt: skip
        samples, stamps = pull_until(inlet, 2)
        after = pylsl.local_clock()
    app.state.engine.dispose()
    assert info.type() == "Markers"
    assert info.channel_format() == pylsl.cf_string
    assert info.nominal_srate() == pylsl.IRREGULAR_RATE
    markers = [parse_marker(sample[0]) for sample in samples]
    assert [m["event_id"] for m in markers if m] == ids
    assert [m["kind"] for m in markers if m] == ["session.paused", "wizard.note"]
    assert markers[0] is not None
    assert markers[0]["payload"] == {"reason": "break"}
    assert markers[0]["session_id"] == session.id
    assert "looked away" not in json.dumps(samples)  # the note's text stays in the database
    assert all(before - 1.0 <= t <= after for t in stamps)


@pytest.mark.slow
def test_markers_recorded_by_an_inlet_align_an_xdf_file_onto_the_timeline(
    settings: Settings, db_session: DbSession, tmp_path: Path
) -> None:
    """The whole loop on one machine: the server's markers as an inlet receives them (as
    LabRecorder would), saved with an EMG stream in an XDF file, imported back: the EMG
    sample taken when an event happened lands at that event's time."""
    booth = f"lsl-{uuid.uuid4().hex[:6]}"
    study = populate(db_session, participants=1)
    session = db_session.get(Session, study.session_ids[0])
    assert session is not None
    session.booth = booth
    db_session.commit()
    app = create_app(settings.model_copy(update={"lsl": True}))
    with TestClient(app):
        inlet = open_inlet(resolve(f"chameleons-{booth}-events"))
        for kind in ("session.paused", "session.resumed", "prompt.played"):
            with write_session(app.state.sessionmaker, app.state.live_hub) as db:
                events.record(db, kind, source="wizard", study_id=study.study_id,
                              session_id=session.id, payload={})  # fmt: skip
        samples, stamps = pull_until(inlet, 3)
    app.state.engine.dispose()
    assert len(samples) == 3
    markers = XdfStream(1, f"chameleons-{booth}-events", "Markers", "string", 0.0, stamps,
                        samples, source_id="events")  # fmt: skip
    emg_times = [stamps[0] + k * 0.01 for k in range(int((stamps[-1] - stamps[0]) / 0.01) + 50)]
    burst = stamps[1]  # the resume, on this machine's LSL clock
    emg = XdfStream(2, "EMG", "EMG", "float32", 100.0, emg_times,
                    [[1.0 if abs(t - burst) < 0.005 else 0.0] for t in emg_times],
                    labels=["zygomaticus"], source_id="emg")  # fmt: skip
    path = write_xdf(tmp_path / "recorded.xdf", [markers, emg])
    result = import_xdf(db_session, session.id, path, tmp_path / "data")
    db_session.commit()
    assert result.fit.markers == 3
    assert result.fit.residual_ms < 5.0
    (stream,) = result.streams
    table = pq.read_table(tmp_path / "data" / stream.path).to_pandas()
    landed = float(table.loc[table["zygomaticus"] > 0.5, "time"].iloc[0])
    resumed = db_session.scalars(select(Event).where(
        Event.session_id == session.id, Event.kind == "session.resumed")).one()  # fmt: skip
    assert session.started_at is not None
    expected = epoch(resumed.server_time) - epoch(session.started_at)
    assert landed == pytest.approx(expected, abs=0.01)


def test_a_booth_whose_worker_connects_gets_its_stream(db_session: DbSession) -> None:
    booth = f"lsl-{uuid.uuid4().hex[:6]}"
    publisher = MarkerPublisher(build_sessionmaker(db_session.get_bind()))  # type: ignore[arg-type]
    publisher.start()
    try:
        publisher.on_worker(Message(f"worker.{booth}", "connected"))
        info = resolve(f"chameleons-{booth}-events")
    finally:
        publisher.stop()
    assert info.type() == "Markers"
