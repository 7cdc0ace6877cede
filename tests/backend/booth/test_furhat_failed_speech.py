"""A prompt the Furhat could not play, end to end through a real bridge and worker (issue
28): the robot fetches the audio from the URL the server gives it, and with the server's
address left on 127.0.0.1 (``CHAMELEONS_PUBLIC_URL`` unset) a robot on another computer
cannot. The project's Furhat peer answers as Furhat documents it, ``response.speak.start``
and then ``response.speak.end`` with ``failed: true``. The play is logged NOT VOICED with
the reason (never played), and the booth check's test prompt fails naming the URL and the
setting; with the public URL set to an address the robot reaches, both work."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI

from chameleons.backend.bridge import Bridge
from tests.backend.booth.conftest import (
    new_session,
    running_worker,
    timeline,
    until,
    wait_for_event,
    worker_config,
)
from tests.backend.booth.test_booth_check_speech import run_check
from tests.support.bots import StaffApi, WizardBot
from tests.worker.furhat_peer import FurhatPeer

pytestmark = pytest.mark.usefixtures("flow")
LOOPBACK = "http://127.0.0.1:"
LAN = "http://192.168.1.20:8000"  # the server's address on the robot's network


def _reachable_only_on_the_lan() -> FurhatPeer:
    return FurhatPeer(speech_seconds=0.2, unplayable=lambda url: url.startswith(LOOPBACK))


def _use_public_url(app: FastAPI, url: str) -> None:
    app.state.settings = app.state.settings.model_copy(update={"public_url": url})


def test_the_booth_checks_test_prompt_fails_with_the_url_and_the_public_url_setting(
    app: FastAPI, pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    assert app.state.settings.effective_public_url.startswith(LOOPBACK)  # the default
    with _reachable_only_on_the_lan() as robot:
        config = worker_config(bridge, tmp_path, driver="furhat", robot_url=robot.url)
        with running_worker(bridge, config):
            failed = run_check(pi, bridge, wizard.session_id)["speech"]
            _use_public_url(app, LAN)
            fixed = run_check(pi, bridge, wizard.session_id)["speech"]
    assert failed["status"] == "fail", failed
    value = str(failed["value"])
    (url,) = robot.failed  # the URL the robot was given, in the reason
    assert url.startswith(f"{LOOPBACK}8000/media/prompts/")
    assert value.startswith(f"the robot could not play the audio at {url}; 127.0.0.1 is the "
                            "server's own loopback address")  # fmt: skip
    assert "set CHAMELEONS_PUBLIC_URL to the server's address on the robot's network" in value
    figures = failed["figures"]
    assert isinstance(figures, dict)
    assert figures["ended"] is False
    assert fixed["status"] == "pass", fixed
    assert robot.spoken[0].startswith(f"{LAN}/media/prompts/")


def _played(wizard: WizardBot, play_event_id: int) -> dict[str, dict[str, Any]]:
    return {e["kind"]: e for e in timeline(wizard)
            if (e["payload"] or {}).get("play_event_id") == play_event_id}  # fmt: skip


def _settled(wizard: WizardBot, play_event_id: int) -> dict[str, dict[str, Any]]:
    def over() -> dict[str, dict[str, Any]] | None:
        found = _played(wizard, play_event_id)
        return found if {"prompt.speech_end", "prompt.not_voiced"} & set(found) else None

    found: dict[str, dict[str, Any]] = until(over, what="the play's end")
    return found


def test_a_prompt_the_robot_could_not_play_is_logged_not_voiced_with_the_reason(
    app: FastAPI, pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    wizard, _ = new_session(pi, study_id)
    wizard.start()
    path = f"/api/wizard/sessions/{wizard.session_id}/prompts/play"
    with _reachable_only_on_the_lan() as robot:
        config = worker_config(bridge, tmp_path, driver="furhat", robot_url=robot.url)
        with running_worker(bridge, config):
            wait_for_event(wizard, "robot.connected")
            failed = _settled(wizard, pi.post(path, {"group": "lunar_water_describe"})["event_id"])
            _use_public_url(app, LAN)
            heard = _settled(wizard, pi.post(path, {"group": "lunar_water_describe"})["event_id"])
        wait_for_event(wizard, "robot.disconnected")  # no write left for the teardown
    assert "prompt.speech_end" not in failed  # never logged played
    detail = failed["prompt.not_voiced"]["payload"]["detail"]
    assert detail.startswith(f"the robot could not play the audio at {robot.failed[0]}")
    assert "CHAMELEONS_PUBLIC_URL" in detail
    assert "prompt.speech_start" in failed  # the robot started the speech action, then failed
    assert "prompt.not_voiced" not in heard
    assert heard["prompt.speech_end"]["payload"]["outcome"] == "played"
