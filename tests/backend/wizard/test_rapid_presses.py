"""Rapid presses through a real worker: the wizard plays a prompt while another plays, the
same prompt again (a single-variant group, so the same prompt id) or a different one.
The first play is logged interrupted, never played; the second is credited only from its
own speech events (each play has its own id on the wire, carried through the worker's
speech events), so it is never NOT VOICED because of the first one's end.

Two robots: the ``null`` driver (speech starts at once and ends with the lip-sync curves)
and the project's Furhat peer (:mod:`tests.worker.furhat_peer`, modelled on Furhat's own
Realtime API client: a speech queue, start latency, ``response.speak.start``/``end``)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.display.tokens import display_token, signing_key
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.backend.wizard.conftest import api
from tests.backend.wizard.test_booth_check_virtual import TELEMETRY
from tests.backend.wizard.test_virtual_presence import (  # noqa: F401 - the fixture
    _until_play_audio,
    virtual_worker,
)
from tests.backend.wizard.test_worker_path import ANY_PORT, BOOTH, until
from tests.support.bots import WizardBot
from tests.worker.furhat_peer import FurhatPeer

Bridge = pytest.importorskip("chameleons.backend.bridge").Bridge
SAME = ("lunar_water_describe", "lunar_water_describe")  # one variant: the same prompt twice
DIFFERENT = ("lunar_water_describe", "lunar_oxygen_describe")


@pytest.fixture(params=["null", "furhat"])
def robot_worker(
    request: pytest.FixtureRequest, app: FastAPI, client: TestClient, tmp_path: Path
) -> Iterator[Worker]:
    assert client.portal is not None
    bridge = Bridge(ANY_PORT, ANY_PORT)
    client.portal.call(bridge.start)
    app.state.bridge = bridge
    config = WorkerConfig(booth=BOOTH, driver=request.param, livelink_port=None,
                          facecapturex_port=None, data_dir=tmp_path,
                          command_endpoint=bridge.command_endpoint,
                          telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
    try:
        with FurhatPeer(start_latency=0.2, speech_seconds=3.0) as peer:
            if request.param == "furhat":
                config = replace(config, robot_url=peer.url)
            with Worker(config) as running:
                until(lambda: (bridge.latest_telemetry(BOOTH)[0] or {}).get("robot_connected"),
                      timeout=20)  # fmt: skip
                yield running
    finally:
        client.portal.call(bridge.stop)


def events_of(wizard: WizardBot, play_event_id: int) -> dict[str, dict[str, Any]]:
    events = wizard.staff.get(f"/api/sessions/{wizard.session_id}/events")
    return {e["kind"]: e for e in events
            if (e["payload"] or {}).get("play_event_id") == play_event_id}  # fmt: skip


def settled(wizard: WizardBot, play_event_id: int) -> dict[str, dict[str, Any]]:
    """The play's events once it ended or was found not voiced."""

    def over() -> dict[str, dict[str, Any]] | None:
        found = events_of(wizard, play_event_id)
        return found if {"prompt.speech_end", "prompt.not_voiced"} & set(found) else None

    result: dict[str, dict[str, Any]] = until(over, timeout=30)
    return result


def press(wizard: WizardBot, group: str) -> int:
    result = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": group})
    assert result["sent"] is True, result
    return int(result["event_id"])


@pytest.mark.usefixtures("robot_worker")
@pytest.mark.parametrize("groups", [SAME, DIFFERENT], ids=["same_prompt", "different_prompts"])
def test_a_second_press_while_the_first_speaks_interrupts_it_and_is_credited_alone(
    wizard: WizardBot, groups: tuple[str, str]
) -> None:
    first = press(wizard, groups[0])
    until(lambda: "prompt.speech_start" in events_of(wizard, first), timeout=20)
    second = press(wizard, groups[1])
    ended, firsts = settled(wizard, second), settled(wizard, first)
    assert firsts["prompt.speech_end"]["payload"]["outcome"] == "interrupted"
    assert "prompt.not_voiced" not in firsts
    assert "prompt.not_voiced" not in ended, ended["prompt.not_voiced"]["payload"]
    assert "prompt.speech_start" in ended
    start, end = ended["prompt.speech_start"], ended["prompt.speech_end"]
    assert end["payload"].get("outcome") in (None, "played"), end["payload"]
    assert start["id"] < end["id"]
    # The second's start came after it was sent, not from the first play's events.
    assert start["payload"]["click_to_speech_ms"] >= 0
    assert end["server_time"] > firsts["prompt.speech_end"]["server_time"]


def test_the_display_pages_end_of_the_first_play_is_not_the_second_plays(
    app: FastAPI, client: TestClient, wizard: WizardBot, virtual_worker: Worker,  # noqa: F811
) -> None:  # fmt: skip
    """The virtual robot: the page (a real WebSocket client speaking the page's protocol)
    reports the first play's end, interrupted, after the second play reached it; it
    carries the first play's id, so the worker and the server keep it apart from the
    second play of the same prompt."""
    path = f"/ws/display/{BOOTH}?token={display_token(signing_key(app), BOOTH)}"
    with client.websocket_connect(path) as page:
        page.send_text(json.dumps(TELEMETRY))
        first = press(wizard, SAME[0])
        one = _until_play_audio(page)
        page.send_text(json.dumps(speech_report(one, "start")))
        until(lambda: "prompt.speech_start" in events_of(wizard, first), timeout=20)
        second = press(wizard, SAME[1])
        two = _until_play_audio(page)
        assert (one["prompt_id"], one["play_id"]) == (two["prompt_id"], f"play-{first}")
        assert two["play_id"] == f"play-{second}"
        page.send_text(json.dumps(speech_report(one, "end", reason="interrupted")))
        page.send_text(json.dumps(speech_report(two, "start")))
        until(lambda: "prompt.speech_start" in events_of(wizard, second), timeout=20)
        page.send_text(json.dumps(speech_report(two, "end", reason="ended")))
        ended, firsts = settled(wizard, second), settled(wizard, first)
    assert firsts["prompt.speech_end"]["payload"]["outcome"] == "interrupted"
    assert "prompt.not_voiced" not in ended, ended["prompt.not_voiced"]["payload"]
    assert ended["prompt.speech_end"]["payload"].get("outcome") != "interrupted"
    assert ended["prompt.speech_start"]["id"] < ended["prompt.speech_end"]["id"]


def speech_report(play: dict[str, Any], event: str, **extra: Any) -> dict[str, Any]:
    return {"type": "speech", "event": event, "play_id": play["play_id"],
            "prompt_id": play["prompt_id"], **extra}  # fmt: skip
