"""Outages reach the timeline of the session running on the booth and the dashboard's flags;
without a worker the booth flow logs why nothing happened and the session goes on."""

from __future__ import annotations

import socket
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import select

from chameleons.backend.booth.flows import BoothFlow
from chameleons.backend.bridge import Bridge
from chameleons.backend.dashboard.flags import session_flags
from chameleons.backend.models import Recording, Session, Study
from chameleons.backend.studies.specs import spec_of
from chameleons.worker.runtime import Worker
from tests.backend.booth.conftest import (
    feed_face,
    finish_interaction,
    new_session,
    participant_frames_recorded,
    running_worker,
    start_flow,
    timeline,
    until,
    wait_for_event,
    worker_config,
)
from tests.backend.booth.test_flow_with_worker import interaction_id
from tests.support.bots import StaffApi, WizardBot


def outage_flags(app: FastAPI, session_id: int) -> list[str]:
    with app.state.sessionmaker() as db:
        session = db.get(Session, session_id)
        study = db.get(Study, session.study_id) if session else None
        assert session is not None
        assert study is not None
        flags = session_flags(db, spec_of(study), [session])[session_id]
        return [flag.text for flag in flags.of("outage")]


def indexed(app: FastAPI, wizard: WizardBot) -> list[Recording]:
    with app.state.sessionmaker() as db:
        query = select(Recording).where(Recording.interaction_id == interaction_id(app, wizard))
        return list(db.scalars(query))


@pytest.mark.usefixtures("flow")
def test_a_worker_lost_and_restarted_mid_interaction_is_flagged_and_still_recorded(
    app: FastAPI, pi: StaffApi, study_id: int, bridge: Bridge, worker: Worker, tmp_path: Path
) -> None:
    wizard, phone = new_session(pi, study_id)
    wizard.start()
    wizard.advance(1, "discussion")
    wait_for_event(wizard, "recording.started")
    feed_face(worker)  # more than one chunk (64 frames), so some reach the journal
    until(lambda: participant_frames_recorded(worker) > 0, what="participant frames")
    worker.stop()

    lost = wait_for_event(wizard, "worker.lost")
    assert (lost["source"], lost["interaction_id"]) == ("bridge", interaction_id(app, wizard))
    assert lost["payload"]["position"] == 1
    assert "interaction 1: worker.lost" in outage_flags(app, wizard.session_id)
    page = pi.http.get(f"/pi/sessions/{wizard.session_id}")
    assert "worker.lost" in page.text

    # A new instance of the booth's worker: the bridge replays the recording, which goes on
    # in a second part; the end of the interaction indexes both.
    with running_worker(bridge, worker_config(bridge, tmp_path)) as again:
        wait_for_event(wizard, "worker.restarted")
        assert "interaction 1: worker.restarted" in outage_flags(app, wizard.session_id)
        until(lambda: again.recorder.interaction is not None, what="the replayed recording")

        finish_interaction(wizard, phone, 1, lambda: None)
        wait_for_event(wizard, "recording.stopped")
    # (The lost worker's own closing report may or may not have made it out before its hub
    # stopped: either that report or the directory scan at the stop indexed its files.)
    rows = indexed(app, wizard)
    assert len(rows) == 4  # participant + agent, before and after the restart
    assert sum("-part2-" in r.path for r in rows) == 2
    participant = [r for r in rows if r.stream == "participant"]
    before = next(r for r in participant if "-part2-" not in r.path)
    assert before.frames > 0  # what the lost worker recorded is kept


def _closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@pytest.mark.usefixtures("flow")
def test_a_robot_that_cannot_be_reached_is_an_outage_of_the_running_interaction(
    app: FastAPI, pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    wizard.start()
    wizard.advance(1, "discussion")
    wait_for_event(wizard, "recording.not_started")  # no worker yet
    config = worker_config(bridge, tmp_path, driver="furhat",
                           robot_url=f"ws://127.0.0.1:{_closed_port()}/v1/events")  # fmt: skip
    with running_worker(bridge, config):
        event = wait_for_event(wizard, "robot.disconnected")
        wait_for_event(wizard, "worker.connected")
    assert event["interaction_id"] == interaction_id(app, wizard)
    assert event["worker_time"] is not None
    assert "interaction 1: robot.disconnected" in outage_flags(app, wizard.session_id)


@pytest.fixture
def flow_without_bridge(app: FastAPI, client: TestClient) -> Iterator[BoothFlow]:
    yield from start_flow(app, client, None)


@pytest.mark.usefixtures("flow_without_bridge")
def test_without_a_worker_bridge_the_flow_says_why_and_the_session_goes_on(
    app: FastAPI, pi: StaffApi, study_id: int
) -> None:
    wizard, phone = new_session(pi, study_id)
    wizard.start()
    wizard.advance(1, "discussion")
    not_applied = wait_for_event(wizard, "robot.not_applied")
    assert not_applied["payload"]["behaviour"]["reason"] == "no_worker"
    assert not_applied["payload"]["face_result"]["reason"] == "no_worker"
    not_started = wait_for_event(wizard, "recording.not_started")
    assert not_started["payload"]["reason"] == "no_worker"
    assert "worker unreachable" in not_started["payload"]["detail"]

    finish_interaction(wizard, phone, 1, lambda: None)
    assert wizard.refresh()["interactions"][0]["state"] == "done"
    wizard.advance(2, "discussion")
    # Interaction 1's event is already there: wait for the second one itself.
    until(lambda: [e["kind"] for e in timeline(wizard)].count("recording.not_started") == 2,
          what="interaction 2's recording.not_started")  # fmt: skip
    kinds = [e["kind"] for e in timeline(wizard)]
    assert "recording.stopped" not in kinds
    assert "recording.not_stopped" not in kinds
    assert indexed(app, wizard) == []
    assert outage_flags(app, wizard.session_id) == []  # not an outage: there is no worker


@pytest.mark.usefixtures("flow")
def test_a_bridge_without_the_booth_s_worker_logs_unreachable(
    pi: StaffApi, study_id: int, bridge: Bridge
) -> None:
    wizard, _ = new_session(pi, study_id)
    wizard.start()
    wizard.advance(1, "discussion")
    assert wait_for_event(wizard, "recording.not_started")["payload"]["reason"] == "unreachable"
    assert wait_for_event(wizard, "robot.not_applied")["payload"]["behaviour"]["reason"] == (
        "unreachable"
    )
