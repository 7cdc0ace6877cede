"""A real bridge on the app's loop, the booth flow listening, and a real worker (null driver,
threads in this process, a Live Link receiver on a free port) that a simulated phone feeds."""

from __future__ import annotations

import contextlib
import random
import time
from collections.abc import Callable, Iterator
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from chameleons.backend.booth.flows import BoothFlow
from chameleons.backend.bridge import Bridge
from chameleons.worker.runtime import Worker, WorkerConfig
from chameleons.worker.simulate import LiveLinkSender, SyntheticFace
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, staff_api, study_with_plan

ANY_PORT = "tcp://127.0.0.1:*"
BOOTH = "booth-1"


def until(condition: Callable[[], Any], timeout: float = 30.0, what: str = "condition") -> Any:
    """Poll ``condition`` until it gives something truthy, up to a deadline."""
    deadline = time.monotonic() + timeout
    while not (result := condition()):
        if time.monotonic() > deadline:
            raise AssertionError(f"{what} not met within {timeout} s")
        time.sleep(0.02)
    return result


@pytest.fixture
def pi(client: TestClient, engine: Engine) -> StaffApi:
    return staff_api(client, engine, "pi")


@pytest.fixture
def study_id(pi: StaffApi) -> int:
    return study_with_plan(pi, participants=3)


@pytest.fixture
def bridge(app: FastAPI, client: TestClient) -> Iterator[Bridge]:
    """A bridge on the app's own event loop, handed to the app; workers go stale quickly."""
    assert client.portal is not None
    bridge = Bridge(ANY_PORT, ANY_PORT, stale_after=0.6)
    client.portal.call(bridge.start)
    app.state.bridge = bridge
    yield bridge
    app.state.bridge = None
    client.portal.call(bridge.stop)


def start_flow(app: FastAPI, client: TestClient, bridge: Bridge | None) -> Iterator[BoothFlow]:
    assert client.portal is not None
    flow = BoothFlow(app.state)
    client.portal.call(flow.start, bridge)
    yield flow
    # As the server does: let queued jobs finish (a cancelled job's database write would go
    # on in its thread and collide with the next test's table reset).
    client.portal.call(partial(flow.stop, drain_seconds=5.0))


@pytest.fixture
def flow(app: FastAPI, client: TestClient, bridge: Bridge) -> Iterator[BoothFlow]:
    yield from start_flow(app, client, bridge)


def worker_config(bridge: Bridge, tmp_path: Path, **changes: Any) -> WorkerConfig:
    config = WorkerConfig(booth=BOOTH, driver="null", livelink_port=0, facecapturex_port=None,
                          capture_host="127.0.0.1", data_dir=tmp_path / "worker",
                          command_endpoint=bridge.command_endpoint,
                          telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
    return replace(config, **changes)


@pytest.fixture
def worker(bridge: Bridge, tmp_path: Path) -> Iterator[Worker]:
    with running_worker(bridge, worker_config(bridge, tmp_path)) as running:
        yield running


@contextlib.contextmanager
def running_worker(bridge: Bridge, config: WorkerConfig) -> Iterator[Worker]:
    """A started worker, known to the bridge; stopped at the end."""
    running = Worker(config).start()
    try:
        until(lambda: running.hub.instance in _instances(bridge), what="the worker's hello")
        yield running
    finally:
        running.stop()


def _instances(bridge: Bridge) -> set[str]:
    return {info.instance for info in bridge.workers().values()}


def new_session(pi: StaffApi, study_id: int) -> tuple[WizardBot, ParticipantBot]:
    wizard = WizardBot.create(pi, study_id, booth=BOOTH)
    return wizard, ParticipantBot(pi.http, wizard.token)


def timeline(wizard: WizardBot) -> list[dict[str, Any]]:
    events: list[dict[str, Any]] = wizard.staff.get(f"/api/sessions/{wizard.session_id}/events")
    return events


def wait_for_event(wizard: WizardBot, kind: str, timeout: float = 10.0) -> dict[str, Any]:
    def found() -> dict[str, Any] | None:
        return next((e for e in reversed(timeline(wizard)) if e["kind"] == kind), None)

    event: dict[str, Any] = until(found, timeout, what=f"a {kind} event")
    return event


def feed_face(worker: Worker, seconds: float = 2.0, seed: int = 1) -> int:
    """Send a synthetic face in the Live Link wire format to the worker, as fast as it goes;
    returns the number of frames sent."""
    sender = LiveLinkSender("127.0.0.1", worker.receivers["livelink"].port, fps=60.0)
    sent = 0
    try:
        for sample in SyntheticFace(seed).samples(60.0, seconds):
            sender.send(sample)
            sent += 1
    finally:
        sender.close()
    return sent


def participant_frames_recorded(worker: Worker) -> int:
    recorder = worker.recorder.recorders.get("participant")
    return recorder.frames_written if recorder is not None else 0


def finish_interaction(
    wizard: WizardBot, phone: ParticipantBot, position: int, before_done: Callable[[], None]
) -> None:
    """From discussion to done through the session API and the phone; ``before_done`` runs
    while the robot part of the interaction is still going."""
    rng = random.Random(position)
    wizard.advance(position, "ranking")
    phone.rank(rng)
    wizard.advance(position, "negotiation")
    wizard.refresh()
    wizard.negotiate(position, lambda _suggestion: True)
    before_done()
    wizard.advance(position, "questionnaire")
    phone.answer_questionnaires(position, rng)
