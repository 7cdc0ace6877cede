"""The booth flow computes an interaction's synchrony in the background once its recording
has stopped and its files are indexed (a real worker recording a fed face)."""

from __future__ import annotations

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.booth.flows import BoothFlow
from chameleons.backend.synchrony import repository
from chameleons.worker.runtime import Worker
from tests.backend.booth.conftest import new_session
from tests.backend.booth.test_flow_with_worker import interaction_id, record_interaction
from tests.support.bots import StaffApi


@pytest.mark.slow
def test_synchrony_is_computed_in_the_background_when_the_recording_stops(
    app: FastAPI, client: TestClient, pi: StaffApi, study_id: int, worker: Worker,
    flow: BoothFlow,
) -> None:  # fmt: skip
    wizard, phone = new_session(pi, study_id)
    wizard.switch_condition("copy", 1)
    wizard.start()
    record_interaction(wizard, phone, worker)
    assert flow.synchrony is not None
    assert client.portal is not None
    client.portal.call(flow.settled)  # the indexing job queues the computation
    client.portal.call(flow.synchrony.settled)
    assert flow.synchrony.computed == 1
    assert flow.synchrony.failed == 0
    target = interaction_id(app, wizard)
    with app.state.sessionmaker() as db:
        row = repository.stored(db, [target])[target]
    # A face fed for two seconds: recorded and measured, too short for a window.
    assert row.reason == "too_short"
    assert "synchrony needs at least 36 s" in row.detail
    assert row.params["window_s"] == 30.0
    assert set(row.recordings)  # the indexed recordings it read
