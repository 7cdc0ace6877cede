"""A session in another language gets that language's recordings on the robot (issue 28:
a Swedish session's robot fetched the English file of the same name, or a 404).

A real bridge and worker (threads in this process) with the virtual robot (the display
page is a WebSocket client speaking the page's protocol, the relay wired as the server
wires it) or a Furhat (the project's Furhat peer); the bytes the robot is served for a
Swedish prompt are compared with the Swedish file and the English one of the same name."""

from __future__ import annotations

import io
import json
from collections.abc import Iterator
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import numpy as np
import pytest
import soundfile
from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.display.channel import get_display_channel
from chameleons.backend.display.media import lipsync_url_for
from chameleons.backend.display.relay import forward_speech_events, relay_envelope
from chameleons.backend.display.tokens import display_token, signing_key
from chameleons.settings import Settings
from chameleons.worker.lipsync import load_lipsync
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.backend.wizard.conftest import api
from tests.backend.wizard.test_booth_check_virtual import TELEMETRY
from tests.backend.wizard.test_virtual_presence import _until_play_audio
from tests.backend.wizard.test_worker_path import ANY_PORT, BOOTH, prompt_events, until
from tests.support.bots import StaffApi, WizardBot, study_with_plan
from tests.worker.furhat_peer import FurhatPeer

Bridge = pytest.importorskip("chameleons.backend.bridge").Bridge
PROMPTS = Path(__file__).resolve().parents[3] / "prompts"


def _bridge(app: FastAPI, client: TestClient) -> Any:
    assert client.portal is not None
    bridge = Bridge(ANY_PORT, ANY_PORT)
    client.portal.call(bridge.start)
    app.state.bridge = bridge
    return bridge


def _config(bridge: Any, driver: str, tmp_path: Path, **extra: Any) -> WorkerConfig:
    return WorkerConfig(booth=BOOTH, driver=driver, livelink_port=None,
                        facecapturex_port=None, data_dir=tmp_path,
                        command_endpoint=bridge.command_endpoint,
                        telemetry_endpoint=bridge.telemetry_endpoint, **extra)  # fmt: skip


@pytest.fixture
def display_worker(
    app: FastAPI, client: TestClient, settings: Settings, tmp_path: Path
) -> Iterator[Worker]:
    """The virtual robot, relayed with the prompt's lip-sync URL as the server does."""
    bridge = _bridge(app, client)
    channel = get_display_channel(app)
    lipsync = partial(lipsync_url_for, settings)
    bridge.add_listener("display.", lambda message: relay_envelope(channel, message, lipsync))
    forward_speech_events(channel, bridge.send_command)
    try:
        with Worker(_config(bridge, "virtual", tmp_path)) as running:
            until(lambda: BOOTH in bridge.workers())
            yield running
    finally:
        client.portal.call(bridge.stop)  # type: ignore[union-attr]


@pytest.fixture
def furhat(app: FastAPI, client: TestClient, tmp_path: Path) -> Iterator[FurhatPeer]:
    bridge = _bridge(app, client)
    try:
        with (
            FurhatPeer(start_latency=0.05, speech_seconds=0.5) as peer,
            Worker(_config(bridge, "furhat", tmp_path, robot_url=peer.url)),
        ):
            until(lambda: (bridge.latest_telemetry(BOOTH)[0] or {}).get("robot_connected"),
                  timeout=20)  # fmt: skip
            yield peer
    finally:
        client.portal.call(bridge.stop)  # type: ignore[union-attr]


def swedish_intro(pi: StaffApi) -> tuple[WizardBot, str, str]:
    """A Swedish session, its first actor and the intro group of its first robot name
    (the same file name, ``audio/intro_<name>.mp3``, in English and in Swedish)."""
    wizard = WizardBot.create(pi, study_with_plan(pi, participants=2), language="sv")
    first = wizard.interaction(1)
    return wizard, str(first["actor"]), f"intro_{str(first['robot_name']).lower()}"


def local(url: str) -> str:
    parts = urlsplit(url)
    return f"{parts.path}?{parts.query}"


@contextmanager
def page_playing(
    app: FastAPI, client: TestClient, wizard: WizardBot, group: str
) -> Iterator[tuple[Any, dict[str, Any]]]:
    """An open display page of the booth, the wizard's play of ``group`` and the page's
    ``play_audio`` message of it."""
    path = f"/ws/display/{BOOTH}?token={display_token(signing_key(app), BOOTH)}"
    with client.websocket_connect(path) as page:
        page.send_text(json.dumps(TELEMETRY))
        result = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": group})
        assert result["text"].startswith("Hej")
        yield page, _until_play_audio(page)


def speech(play: dict[str, Any], event: str, **extra: Any) -> str:
    """The page's speech report of ``play``."""
    return json.dumps({"type": "speech", "event": event, "play_id": play["play_id"],
                       "prompt_id": play["prompt_id"], **extra})  # fmt: skip


@pytest.mark.usefixtures("display_worker")
def test_the_display_is_served_the_swedish_recording_and_curves(
    app: FastAPI, client: TestClient, pi: StaffApi
) -> None:
    wizard, actor, group = swedish_intro(pi)
    with page_playing(app, client, wizard, group) as (page, play):
        audio = client.get(local(play["url"]))
        assert audio.status_code == 200, play["url"]
        swedish = PROMPTS / "sv" / actor / "audio" / f"{group}.mp3"
        assert audio.content == swedish.read_bytes()
        assert audio.content != (PROMPTS / actor / "audio" / f"{group}.mp3").read_bytes()
        assert play["lipsync_url"] is not None
        curves = client.get(local(play["lipsync_url"])).text
        assert curves == (PROMPTS / "sv" / actor / "lipsync" / f"{group}.csv").read_text()
        page.send_text(speech(play, "start", audio_delay_ms=5.0))
        page.send_text(speech(play, "end", reason="ended"))
        until(lambda: "prompt.speech_end" in prompt_events(wizard))
    assert "prompt.not_voiced" not in prompt_events(wizard)


@pytest.mark.usefixtures("display_worker")
def test_audio_the_display_cannot_load_is_not_voiced_for_that_reason(
    app: FastAPI, client: TestClient, pi: StaffApi
) -> None:
    wizard, actor, group = swedish_intro(pi)
    with page_playing(app, client, wizard, group) as (page, play):
        # What the page sends when its audio element cannot load the file (display.js).
        page.send_text(speech(play, "end", reason="error"))
        silent = until(lambda: prompt_events(wizard).get("prompt.not_voiced"), timeout=20)
    assert silent["payload"]["detail"] == (
        "the robot display could not load or play the prompt's audio "
        f"(sv/{actor}/audio/{group}.mp3)"
    )


def test_a_furhat_is_given_the_swedish_recording_as_wav(
    furhat: FurhatPeer, client: TestClient, pi: StaffApi
) -> None:
    wizard, actor, group = swedish_intro(pi)
    result = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": group})
    assert result["sent"] is True, result
    until(lambda: furhat.spoken)
    url = furhat.spoken[0]
    assert urlsplit(url).path.endswith(f"/audio/{group}.wav")
    response = client.get(local(url))
    assert response.status_code == 200, url
    served, _ = soundfile.read(io.BytesIO(response.content), dtype="int16")
    swedish, _ = soundfile.read(PROMPTS / "sv" / actor / "audio" / f"{group}.mp3", dtype="int16")
    english, _ = soundfile.read(PROMPTS / actor / "audio" / f"{group}.mp3", dtype="int16")
    assert np.array_equal(served, swedish)
    assert not (len(served) == len(english) and np.array_equal(served, english))
    # The worker moves the Furhat's lips with the Swedish curves (it loads them itself).
    acked = prompt_events(wizard)["prompt.acked"]["payload"]["result"]
    curves = load_lipsync(PROMPTS / "sv" / actor / "lipsync" / f"{group}.csv")
    english_curves = load_lipsync(PROMPTS / actor / "lipsync" / f"{group}.csv")
    assert acked["lipsync_seconds"] == pytest.approx(curves.duration)
    assert curves.duration != pytest.approx(english_curves.duration)
