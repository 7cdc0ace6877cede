"""An interaction started before the booth's worker connected is caught up when it does: the
robot is set up and the recording starts, once."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi import FastAPI

from chameleons.backend.bridge import Bridge
from tests.backend.booth.conftest import (
    BOOTH,
    new_session,
    running_worker,
    timeline,
    until,
    wait_for_event,
    worker_config,
)
from tests.backend.booth.test_flow_with_worker import interaction_id
from tests.support.bots import StaffApi

pytestmark = pytest.mark.usefixtures("flow")


def test_a_worker_connecting_after_the_start_gets_the_set_up_and_records(
    app: FastAPI, pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    wizard.switch_condition("copy", 1)
    wizard.start()
    face = wizard.interaction(1)["face"]
    wizard.advance(1, "discussion")
    wait_for_event(wizard, "robot.not_applied")  # no worker yet
    wait_for_event(wizard, "recording.not_started")

    with running_worker(bridge, worker_config(bridge, tmp_path)) as worker:
        wait_for_event(wizard, "worker.connected")
        applied = wait_for_event(wizard, "robot.applied")
        started = wait_for_event(wizard, "recording.started")
        until(lambda: worker.recorder.interaction is not None, what="the worker recording")
        assert worker.recorder.interaction == str(interaction_id(app, wizard))

    assert applied["source"] == "server"
    assert (applied["payload"]["condition"], applied["payload"]["face"]) == ("copy", face)
    assert started["interaction_id"] == interaction_id(app, wizard)
    assert bridge.state(BOOTH).behaviour == {"name": "copy", "params": {"delay": 4.0}}
    assert bridge.state(BOOTH).face == {"face_id": face}
    kinds = [e["kind"] for e in timeline(wizard)]
    assert (kinds.count("robot.applied"), kinds.count("recording.started")) == (1, 1)
