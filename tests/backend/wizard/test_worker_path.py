"""Prompts through a real bridge to a real worker (null driver, threads in this process):
the ack and speech times land in the timeline with their latencies; the health strip reads
the worker's heartbeat. And a bridge without a worker: "worker unreachable"."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.display.channel import get_display_channel
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.backend.wizard.conftest import api
from tests.backend.wizard.test_live import next_of
from tests.experiment.study_files import with_natural
from tests.support.bots import WizardBot, study_with_plan

# The bridge is the pipeline engineer's; until it is in the tree these tests cannot run.
Bridge = pytest.importorskip("chameleons.backend.bridge").Bridge

ANY_PORT = "tcp://127.0.0.1:*"
BOOTH = "booth-1"


def until(condition: Callable[[], Any], timeout: float = 30.0) -> Any:
    """Poll ``condition`` until it gives something truthy (not a fixed wait)."""
    deadline = time.monotonic() + timeout
    while not (result := condition()):
        if time.monotonic() > deadline:
            raise AssertionError("condition not met in time")
        time.sleep(0.02)
    return result


@pytest.fixture
def bridge(app: FastAPI, client: TestClient) -> Iterator[Any]:
    """A bridge started on the app's own event loop and handed to the app."""
    assert client.portal is not None
    bridge = Bridge(ANY_PORT, ANY_PORT)
    client.portal.call(bridge.start)
    app.state.bridge = bridge
    yield bridge
    client.portal.call(bridge.stop)


@pytest.fixture
def worker(bridge: Any, tmp_path: Path) -> Iterator[Worker]:
    config = WorkerConfig(booth=BOOTH, driver="null", livelink_port=None,
                          facecapturex_port=None, data_dir=tmp_path,
                          command_endpoint=bridge.command_endpoint,
                          telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
    with Worker(config) as running:
        until(lambda: BOOTH in bridge.workers())
        yield running


def prompt_events(wizard: WizardBot) -> dict[str, dict[str, Any]]:
    events = wizard.staff.get(f"/api/sessions/{wizard.session_id}/events")
    return {e["kind"]: e for e in events if e["kind"].startswith("prompt.")}


@pytest.mark.usefixtures("worker")
def test_a_play_is_acked_and_its_speech_timed(wizard: WizardBot) -> None:
    result = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_yes"})
    assert result["sent"] is True, result["detail"]
    assert result["click_to_ack_ms"] > 0
    events = until(
        lambda: (found := prompt_events(wizard)) and "prompt.speech_end" in found and found
    )
    played, acked = events["prompt.played"], events["prompt.acked"]
    start, end = events["prompt.speech_start"], events["prompt.speech_end"]
    assert acked["payload"]["play_event_id"] == played["id"]
    assert acked["payload"]["click_to_ack_ms"] == result["click_to_ack_ms"]
    assert start["payload"]["play_event_id"] == played["id"]
    assert start["payload"]["click_to_speech_ms"] >= 0
    assert start["worker_time"] is not None
    assert end["worker_time"] >= start["worker_time"]
    assert "prompt.not_sent" not in events


@pytest.mark.usefixtures("worker")
def test_stop_reaches_the_worker(wizard: WizardBot) -> None:
    wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_okay"})
    result = wizard.staff.post(f"{api(wizard)}/prompts/stop")
    assert result["sent"] is True
    assert prompt_events(wizard)["prompt.stopped"]["payload"]["sent"] is True


@pytest.mark.usefixtures("worker")
def test_health_reads_the_worker_heartbeat(client: TestClient, wizard: WizardBot) -> None:
    with client.websocket_connect(f"/ws/wizard/sessions/{wizard.session_id}") as socket:
        checks: dict[str, dict[str, Any]] = {}
        for _ in range(10):  # the first beats come before the renderer's first statistics
            beat = next_of(socket, "health")
            checks = {check["id"]: check for check in beat["checks"]}
            if checks["worker"]["ok"] and checks["robot"]["ok"]:
                break
        assert checks["worker"]["ok"] is True
        assert checks["robot"]["ok"] is True  # the null driver is always connected
        assert checks["input"]["ok"] is False  # no face stream is sent in this test
        assert checks["input"]["failing_for"] is not None


def test_a_bridge_without_the_booth_s_worker_says_unreachable(
    bridge: Any, wizard: WizardBot
) -> None:
    result = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_yes"})
    assert result["sent"] is False
    assert result["reason"] == "unreachable"
    assert "unreachable" in result["detail"]
    assert prompt_events(wizard)["prompt.not_sent"]["payload"]["reason"] == "unreachable"


@pytest.mark.usefixtures("worker")
def test_the_robot_is_set_to_the_interaction_s_condition_and_face(
    wizard: WizardBot, bridge: Any
) -> None:
    wizard.switch_condition("copy", 1)
    result = wizard.staff.post(f"{api(wizard)}/robot/apply")
    assert result["kind"] == "robot.applied", result
    assert (result["condition"], result["face"]) == ("copy", wizard.interaction(1)["face"])
    assert bridge.state(BOOTH).behaviour == {"name": "copy", "params": {"delay": 4.0}}
    assert bridge.state(BOOTH).face == {"face_id": wizard.interaction(1)["face"]}
    events = wizard.staff.get(f"/api/sessions/{wizard.session_id}/events")
    assert events[-1]["kind"] == "robot.applied"


@pytest.mark.usefixtures("worker")
def test_a_refusal_by_the_worker_is_logged_with_its_reason(wizard: WizardBot) -> None:
    # ``natural`` works out of the box (the shipped clip): a study naming a clip that is not
    # in the prompts folder is refused by the worker instead, with the file it looked for.
    study = study_with_plan(wizard.staff, 2, yaml=with_natural(clip="no-such-clip"))
    wizard = WizardBot.create(wizard.staff, study)
    wizard.switch_condition("natural", 1)
    result = wizard.staff.post(f"{api(wizard)}/robot/apply")
    assert result["kind"] == "robot.not_applied"
    assert result["behaviour"]["reason"] == "bad_behaviour"
    assert "motion recording not found" in result["behaviour"]["detail"]
    assert "_natural/no-such-clip.npz" in result["behaviour"]["detail"]
    assert result["face_result"]["sent"] is True


def test_without_a_worker_the_robot_set_up_is_logged_as_not_applied(
    bridge: Any, wizard: WizardBot
) -> None:
    result = wizard.staff.post(f"{api(wizard)}/robot/apply")
    assert result["kind"] == "robot.not_applied"
    assert result["behaviour"]["reason"] == "unreachable"
    assert result["face_result"]["reason"] == "unreachable"


@pytest.mark.usefixtures("worker")
def test_a_play_the_robot_display_cannot_start_tells_the_console_why(
    app: FastAPI, client: TestClient, wizard: WizardBot
) -> None:
    channel = get_display_channel(app)
    result = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_yes"})
    assert result["sent"] is True, result["detail"]
    played = prompt_events(wizard)["prompt.played"]
    # What the page reports when its browser blocks sound (the Chromium case is tested in
    # tests/e2e/display/test_display_sound_hint.py), through the server's display channel.
    prompt_id = played["payload"]["prompt_id"]
    report = {"type": "speech", "event": "end", "play_id": "p#1", "prompt_id": prompt_id,
              "reason": "autoplay_blocked"}  # fmt: skip
    assert client.portal is not None
    client.portal.call(channel.report, BOOTH, report)

    def blocked() -> dict[str, Any] | None:
        events = wizard.staff.get(f"/api/sessions/{wizard.session_id}/events")
        return next((e for e in events if e["kind"] == "prompt.speech_end"
                     and e["payload"].get("reason")), None)  # fmt: skip

    end = until(blocked)
    assert end["source"] == "display"
    assert end["payload"]["play_event_id"] == played["id"]
    assert end["payload"]["reason"] == "autoplay_blocked"
    assert end["payload"]["detail"] == "robot display needs a click to enable sound"
