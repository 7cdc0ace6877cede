"""The virtual robot is "connected" only while a display page of its booth is open and
playing; a prompt no robot voiced is logged NOT VOICED and flagged on the dashboard.

A real bridge and a real worker with the ``virtual`` driver (threads in this process); the
display page is a real WebSocket client of ``/ws/display/<booth>`` speaking the page's
protocol (:mod:`chameleons.backend.display.protocol`), wired to the bridge as the server
wires it (:mod:`chameleons.backend.bridge.wiring`)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.dashboard.flags import session_flags
from chameleons.backend.display.channel import get_display_channel
from chameleons.backend.display.relay import forward_speech_events, relay_envelope
from chameleons.backend.display.tokens import display_token, signing_key
from chameleons.backend.models import Session, Study
from chameleons.backend.studies.specs import spec_of
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.backend.wizard.conftest import api
from tests.backend.wizard.test_live import next_of
from tests.backend.wizard.test_worker_path import BOOTH, prompt_events, until
from tests.support.bots import WizardBot

Bridge = pytest.importorskip("chameleons.backend.bridge").Bridge


@pytest.fixture
def virtual_worker(app: FastAPI, client: TestClient, tmp_path: Path) -> Iterator[Worker]:
    assert client.portal is not None
    bridge = Bridge("tcp://127.0.0.1:*", "tcp://127.0.0.1:*")
    client.portal.call(bridge.start)
    app.state.bridge = bridge
    channel = get_display_channel(app)
    bridge.add_listener("display.", lambda message: relay_envelope(channel, message))
    forward_speech_events(channel, bridge.send_command)
    config = WorkerConfig(booth=BOOTH, driver="virtual", livelink_port=None,
                          facecapturex_port=None, data_dir=tmp_path,
                          command_endpoint=bridge.command_endpoint,
                          telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
    try:
        with Worker(config) as running:
            until(lambda: BOOTH in bridge.workers())
            yield running
    finally:
        client.portal.call(bridge.stop)


def _robot_chip(client: TestClient, wizard: WizardBot, wanted: str) -> dict[str, Any]:
    with client.websocket_connect(f"/ws/wizard/sessions/{wizard.session_id}") as socket:
        for _ in range(20):  # the first beats may come before the worker's heartbeat
            checks: dict[str, dict[str, Any]] = {
                c["id"]: c for c in next_of(socket, "health")["checks"]
            }
            if checks["robot"]["value"] == wanted:
                return checks["robot"]
    raise AssertionError(f"the robot chip never read {wanted!r}: {checks['robot']}")


def _flags(app: FastAPI, session_id: int) -> list[str]:
    with app.state.sessionmaker() as db:
        session = db.get(Session, session_id)
        assert session is not None
        study = db.get(Study, session.study_id)
        assert study is not None
        flags = session_flags(db, spec_of(study), [session])[session_id]
        return [flag.text for flag in flags.of("not_voiced")]


@pytest.mark.usefixtures("virtual_worker")
def test_without_a_display_page_the_robot_is_red_and_a_prompt_is_not_voiced(
    app: FastAPI, client: TestClient, wizard: WizardBot
) -> None:
    chip = _robot_chip(client, wizard, "no robot display open")
    assert chip["ok"] is False
    result = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_yes"})
    assert result["sent"] is True  # the worker got it; nobody voiced it
    silent = until(lambda: prompt_events(wizard).get("prompt.not_voiced"), timeout=20)
    events = prompt_events(wizard)
    assert silent["payload"]["detail"] == f"no robot display open for {BOOTH}"
    assert silent["payload"]["play_event_id"] == events["prompt.played"]["id"]
    assert "prompt.speech_start" not in events
    [flag] = _flags(app, wizard.session_id)
    assert "not voiced (no robot display open" in flag


def _until_play_audio(ws: Any) -> dict[str, Any]:
    for _ in range(5000):  # face and head frames stream in between
        message: dict[str, Any] = json.loads(ws.receive_text())
        if message["type"] == "play_audio":
            return message
    raise AssertionError("no play_audio reached the page")


@pytest.mark.usefixtures("virtual_worker")
def test_an_open_playing_display_is_the_connected_robot_and_voices_the_prompt(
    app: FastAPI, client: TestClient, wizard: WizardBot
) -> None:
    path = f"/ws/display/{BOOTH}?token={display_token(signing_key(app), BOOTH)}"
    telemetry = {"type": "telemetry", "fps": 60.0, "frames_in": 25.0, "speaking": False,
                 "face": "face-1"}  # fmt: skip
    with client.websocket_connect(path) as page:
        page.send_text(json.dumps(telemetry))
        assert _robot_chip(client, wizard, "display open")["ok"] is True
        result = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_yes"})
        assert result["sent"] is True
        play = _until_play_audio(page)
        speech = {"type": "speech", "play_id": play["play_id"], "prompt_id": play["prompt_id"]}
        page.send_text(json.dumps({**speech, "event": "start", "audio_delay_ms": 12.0}))
        until(lambda: "prompt.speech_start" in prompt_events(wizard))
        page.send_text(json.dumps({**speech, "event": "end", "reason": "ended"}))
        until(lambda: "prompt.speech_end" in prompt_events(wizard))
    assert "prompt.not_voiced" not in prompt_events(wizard)
    assert _flags(app, wizard.session_id) == []
