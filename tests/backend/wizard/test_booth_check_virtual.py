"""The booth check's test prompt with the virtual robot: a real worker (virtual driver), a
real bridge, and the robot display page as a real WebSocket client of
``/ws/display/<booth>`` speaking the page's protocol. The step passes only when the page
reports the prompt's speech start and end; with no page open it fails."""

from __future__ import annotations

import json
import threading
from typing import Any

from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.display.tokens import display_token, signing_key
from chameleons.worker.runtime import Worker
from tests.backend.wizard.test_virtual_presence import (  # noqa: F401 - the fixture
    _until_play_audio,
    virtual_worker,
)
from tests.backend.wizard.test_worker_path import BOOTH, until
from tests.support.bots import WizardBot

TELEMETRY = {"type": "telemetry", "fps": 60.0, "frames_in": 25.0, "speaking": False,
             "face": "face-1"}  # fmt: skip


def heartbeat(app: FastAPI) -> bool:
    return bool(app.state.bridge.latest_telemetry(BOOTH)[0])


def driving(app: FastAPI) -> bool:
    """A heartbeat naming the virtual driver (the renderer stage has reported: the first
    beats may come before it, and the Robot step reads the driver from them)."""
    telemetry = app.state.bridge.latest_telemetry(BOOTH)[0] or {}
    return bool(telemetry.get("driver") == "virtual")


def speech_step(result: dict[str, Any]) -> dict[str, Any]:
    step: dict[str, Any] = next(s for s in result["steps"] if s["id"] == "speech")
    return step


def check_with_page(
    app: FastAPI, client: TestClient, wizard: WizardBot, fps: list[float]
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Run the check (no head movement) with the display page as a WebSocket peer that
    reports ``fps[0]`` before the check, the rest once the test prompt reached it, and
    then the prompt's speech start and end; returns the check's answer and the play."""
    until(lambda: driving(app))
    path = f"/ws/display/{BOOTH}?token={display_token(signing_key(app), BOOTH)}"
    answer: dict[str, Any] = {}

    def run_check() -> None:
        answer.update(wizard.staff.post(f"/api/booths/{BOOTH}/check?movement=false"))

    with client.websocket_connect(path) as page:
        page.send_text(json.dumps({**TELEMETRY, "fps": fps[0]}))
        checking = threading.Thread(target=run_check)
        checking.start()
        play = _until_play_audio(page)
        for rate in fps[1:]:
            page.send_text(json.dumps({**TELEMETRY, "fps": rate}))
        speech = {"type": "speech", "play_id": play["play_id"], "prompt_id": play["prompt_id"]}
        page.send_text(json.dumps({**speech, "event": "start", "audio_delay_ms": 12.0}))
        page.send_text(json.dumps({**speech, "event": "end", "reason": "ended"}))
        checking.join(timeout=60)
    assert not checking.is_alive()
    return answer, play


def test_the_display_page_voices_the_test_prompt(
    app: FastAPI, client: TestClient, wizard: WizardBot, virtual_worker: Worker,  # noqa: F811
) -> None:  # fmt: skip
    answer, play = check_with_page(app, client, wizard, [60.0])
    step = speech_step(answer)
    assert step["status"] == "pass", step
    assert str(play["prompt_id"]).startswith("booth-check:")
    assert step["figures"]["ended"] is True
    robot = next(s for s in answer["steps"] if s["id"] == "robot")
    assert (robot["status"], robot["value"]) == ("pass", "the display: display open")
    assert robot["figures"] == {"display_fps": 60.0}


def test_without_a_display_page_the_test_prompt_fails(
    app: FastAPI, wizard: WizardBot, virtual_worker: Worker,  # noqa: F811
) -> None:  # fmt: skip
    until(lambda: heartbeat(app))
    step = speech_step(wizard.staff.post(f"/api/booths/{BOOTH}/check?movement=false"))
    assert step["status"] == "fail"
    assert step["value"] == "the robot never started speaking"


def test_a_display_painting_a_frame_or_two_a_second_passes_with_a_warning(
    app: FastAPI, client: TestClient, wizard: WizardBot, virtual_worker: Worker,  # noqa: F811
) -> None:  # fmt: skip
    """A page in a background tab plays (it reports, fps > 0) but paints 1-2 frames a second:
    the check stays ready (the speech step passes) and its Robot step says why it warns."""
    answer, _ = check_with_page(app, client, wizard, [2.0, 1.0])
    assert speech_step(answer)["status"] == "pass"
    robot = next(s for s in answer["steps"] if s["id"] == "robot")
    assert robot["status"] == "warn", robot
    assert robot["figures"]["display_fps"] == 1.5
    assert "painted only 2 frames a second during the check" in robot["value"]
