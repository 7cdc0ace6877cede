"""The booth check's test prompt against the project's Furhat peer (modelled on Furhat's own
Realtime API client: a speech queue, start latency, ``response.speak.start``/``end``): the
robot says a recorded prompt and the check passes only when the robot reports both its
speech start and end; a robot that never starts speaking fails the step. The result is
stored in the ``booth_check`` table."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi import FastAPI
from sqlalchemy import select

from chameleons.backend.bridge import Bridge
from chameleons.backend.models import BoothCheck
from tests.backend.booth.conftest import (
    BOOTH,
    new_session,
    running_worker,
    until,
    worker_config,
)
from tests.support.bots import StaffApi
from tests.worker.furhat_peer import FurhatPeer

pytestmark = pytest.mark.usefixtures("flow")


def run_check(pi: StaffApi, bridge: Bridge, session_id: int) -> dict[str, dict[str, object]]:
    until(lambda: bridge.latest_telemetry(BOOTH)[0], what="the worker's heartbeat")
    result = pi.post(f"/api/booths/{BOOTH}/check?session_id={session_id}&movement=false")
    return {s["id"]: s for s in result["steps"]}


def test_the_robot_says_the_test_prompt_and_reports_start_and_end(
    app: FastAPI, pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    with FurhatPeer(start_latency=0.15, speech_seconds=0.3) as peer:
        config = worker_config(bridge, tmp_path, driver="furhat", robot_url=peer.url)
        with running_worker(bridge, config):
            steps = run_check(pi, bridge, wizard.session_id)
    speech = steps["speech"]
    assert speech["status"] == "pass", speech
    figures = speech["figures"]
    assert isinstance(figures, dict)
    assert figures["ended"] is True
    assert float(figures["start_ms"]) >= 150.0  # the robot's own start latency at least
    assert str(figures["prompt_id"]).startswith("booth-check:")
    assert len(peer.spoken) == 1
    assert "/media/prompts/" in peer.spoken[0]
    assert peer.spoken[0].split("?")[0].endswith(".wav")  # a Furhat is sent WAV
    with app.state.sessionmaker() as db:
        row = db.scalars(select(BoothCheck).where(BoothCheck.session_id == wizard.session_id)).one()
    assert row.speech_ok is True
    assert row.speech_start_ms == figures["start_ms"]


def test_a_robot_that_never_speaks_fails_the_step(
    app: FastAPI, pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    with FurhatPeer(start_latency=60.0) as peer:
        config = worker_config(bridge, tmp_path, driver="furhat", robot_url=peer.url)
        with running_worker(bridge, config):
            steps = run_check(pi, bridge, wizard.session_id)
    assert steps["speech"]["status"] == "fail"
    assert steps["speech"]["value"] == "the robot never started speaking"
    with app.state.sessionmaker() as db:
        row = db.scalars(select(BoothCheck).where(BoothCheck.session_id == wizard.session_id)).one()
    assert (row.speech_ok, row.passed) == (False, False)
