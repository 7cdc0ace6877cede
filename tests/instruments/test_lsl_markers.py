"""``CHAMELEONS_LSL=1``: the server publishes every committed timeline event of a booth's
session as a marker on ``chameleons-<booth>-events``; a real LSL inlet on this machine
reads them, stamped with the events' times on LSL's clock, free text left out."""

from __future__ import annotations

import json
import uuid

import pylsl
import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.app import create_app
from chameleons.backend.events import repository as events
from chameleons.backend.events.unit_of_work import write_session
from chameleons.backend.models import Session
from chameleons.instruments.lsl import parse_marker
from chameleons.settings import Settings
from tests.instruments.lsl_inlets import open_inlet, pull_until, resolve
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
