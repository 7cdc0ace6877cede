"""The console's robot health at a booth with both robots (``--driver virtual+furhat``, the
``embodiment`` template): the *Robot* chip judges the robot driven now and says which, and
the robot a later condition of the study needs gets a chip of its own that says when it is
missing (no display page open, the Furhat not connected) and which conditions need it.

A real bridge and worker (threads in this process), the Furhat test peer, and the display
page as a real WebSocket client of ``/ws/display/<booth>``, wired to the bridge as the
server wires it; the chips are read from the console's own WebSocket."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.display.channel import get_display_channel
from chameleons.backend.display.relay import forward_speech_events, relay_envelope
from chameleons.backend.display.tokens import display_token, signing_key
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.backend.wizard.conftest import api
from tests.backend.wizard.test_robot_renderer import furhat_study
from tests.backend.wizard.test_worker_path import BOOTH, bridge, until
from tests.support.bots import WizardBot, study_with_plan
from tests.worker.furhat_peer import FurhatPeer

__all__ = ["bridge"]
pytestmark = pytest.mark.slow
PAGE_TELEMETRY = {"type": "telemetry", "fps": 60.0, "frames_in": 25.0, "speaking": False,
                  "face": "face-1"}  # fmt: skip


def chips(client: TestClient, wizard: WizardBot) -> dict[str, dict[str, Any]]:
    """The health chips a console opening now is sent first (a fresh connection: the
    feed sends a health only when it changed)."""
    with client.websocket_connect(f"/ws/wizard/sessions/{wizard.session_id}") as socket:
        for _ in range(20):
            message: dict[str, Any] = socket.receive_json()
            if message["type"] == "health":
                return {c["id"]: c for c in message["checks"]}
    raise AssertionError("no health message")


def chips_when(
    client: TestClient, wizard: WizardBot, page: Any = None, **wanted: str
) -> dict[str, Any]:
    """The chips once each named chip reads its wanted value (a prefix ending in ``...``);
    an open display ``page`` reports its telemetry meanwhile, as a playing page does."""

    def matches(found: dict[str, dict[str, Any]]) -> bool:
        for chip, value in wanted.items():
            seen = str(found.get(chip, {}).get("value"))
            if not (seen.startswith(value[:-3]) if value.endswith("...") else seen == value):
                return False
        return True

    last: dict[str, Any] = {}

    def read() -> bool:
        if page is not None:
            page.send_text(json.dumps(PAGE_TELEMETRY))
        last.clear()
        last.update(chips(client, wizard))
        return matches(last)

    try:
        until(read, timeout=30)
    except AssertionError:
        raise AssertionError(f"the chips never read {wanted}: {last}") from None
    return last


def apply(wizard: WizardBot, condition: str) -> None:
    wizard.switch_condition(condition, 1)
    result = wizard.staff.post(f"{api(wizard)}/robot/apply")
    assert result["kind"] == "robot.applied", result


def test_each_robot_the_study_needs_is_judged_and_a_missing_one_named(
    app: FastAPI, client: TestClient, pi: Any, bridge: Any, tmp_path: Path
) -> None:
    channel = get_display_channel(app)
    bridge.add_listener("display.", lambda message: relay_envelope(channel, message))
    forward_speech_events(channel, bridge.send_command)
    wizard = WizardBot.create(pi, study_with_plan(pi, 6, yaml=furhat_study()))
    with contextlib.ExitStack() as furhat:
        robot = furhat.enter_context(FurhatPeer())
        config = WorkerConfig(booth=BOOTH, driver="virtual+furhat", robot_url=robot.url,
                              livelink_port=None, facecapturex_port=None, data_dir=tmp_path,
                              command_endpoint=bridge.command_endpoint,
                              telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
        with Worker(config):
            until(lambda: BOOTH in bridge.workers())
            # The worker starts on the display, and no display page is open: red, and the
            # Furhat, connected, is ready for the study's Furhat condition.
            found = chips_when(client, wizard,
                               robot="no robot display open (the display runs now)",
                               furhat="connected (for copy_furhat)")  # fmt: skip
            assert (found["robot"]["level"], found["furhat"]["level"]) == ("alarm", "ok")
            assert found["furhat"]["label"] == "Furhat"
            assert "display" not in found  # the display is the Robot chip now

            apply(wizard, "copy_furhat")
            found = chips_when(
                client,
                wizard,
                robot="connected (the Furhat runs now)",
                display="no robot display open; copy_2d, still need it",
            )
            assert found["robot"]["ok"] is True
            assert (found["display"]["label"], found["display"]["level"]) == (
                "Robot display", "degraded")  # fmt: skip

            path = f"/ws/display/{BOOTH}?token={display_token(signing_key(app), BOOTH)}"
            with client.websocket_connect(path) as page:
                found = chips_when(
                    client, wizard, page, display="display open (for copy_2d, still)"
                )
                assert found["display"]["ok"] is True

                apply(wizard, "copy_2d")
                chips_when(client, wizard, page, robot="display open (the display runs now)",
                           furhat="connected (for copy_furhat)")  # fmt: skip
                furhat.close()  # the Furhat goes away
                found = chips_when(client, wizard, page, furhat="disconnected...",
                                   robot="display open (the display runs now)")  # fmt: skip
                assert found["furhat"]["value"].endswith("; copy_furhat needs it")
                assert (found["furhat"]["ok"], found["furhat"]["level"]) == (False, "degraded")


def test_a_booth_without_a_furhat_says_the_furhat_conditions_cannot_run(
    client: TestClient, pi: Any, bridge: Any, tmp_path: Path
) -> None:
    wizard = WizardBot.create(pi, study_with_plan(pi, 6, yaml=furhat_study()))
    config = WorkerConfig(booth=BOOTH, driver="null", livelink_port=None,
                          facecapturex_port=None, data_dir=tmp_path,
                          command_endpoint=bridge.command_endpoint,
                          telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
    with Worker(config):
        until(lambda: BOOTH in bridge.workers())
        found = chips_when(client, wizard, furhat=(
            "this booth drives no Furhat (its worker's driver is null): copy_furhat cannot "
            "run"))  # fmt: skip
    assert found["robot"]["value"] == "connected"
    assert found["furhat"]["level"] == "degraded"
