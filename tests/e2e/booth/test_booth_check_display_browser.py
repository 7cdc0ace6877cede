"""The booth check's speech step with the virtual robot, all in Chromium: the app runs its
own worker link (bridge, display relay, speech forwarding, as ``bridge/wiring.py`` starts it
in a real server), a real worker with the ``virtual`` driver connects to it, the robot
display page is open in one tab and plays the test prompt's audio, and the technician runs
the check from the booth check page in another. The step passes only when the page's own
speech start and end came back; the page's report of the play is what the step reads."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from fastapi import FastAPI
from playwright.sync_api import BrowserContext, Page, WebSocket, expect
from sqlalchemy import Engine

from chameleons.backend.display.tokens import display_path, signing_key
from chameleons.settings import Settings
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.backend.test_auth import add_user
from tests.support.bots import WizardBot, staff_api, study_with_plan
from tests.support.browser import wait_for_js
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser
BOOTH = "booth-3"
ANY_PORT = "tcp://127.0.0.1:*"


@pytest.fixture
def settings(settings: Settings) -> Settings:
    """The server starts its worker link itself (free ports, loopback), as in a lab."""
    return settings.model_copy(update={
        "bridge_enabled": True, "worker_command_endpoint": ANY_PORT,
        "worker_telemetry_endpoint": ANY_PORT,
        "booth_check_turn_seconds": 1.0, "booth_check_nod_seconds": 1.0,
    })  # fmt: skip


@pytest.fixture
def worker(live_server: LiveServer, app: FastAPI, tmp_path: Path) -> Iterator[Worker]:
    bridge = app.state.bridge
    config = WorkerConfig(booth=BOOTH, driver="virtual", livelink_port=None,
                          facecapturex_port=None, data_dir=tmp_path / "worker",
                          command_endpoint=bridge.command_endpoint,
                          telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
    with Worker(config) as running:
        deadline = time.monotonic() + 30
        while BOOTH not in bridge.workers():  # polls the hello; not a fixed wait
            assert time.monotonic() < deadline, "the worker did not say hello"
            time.sleep(0.02)
        yield running


def open_display(
    context: BrowserContext, live_server: LiveServer, app: FastAPI, sent: list[dict[str, Any]]
) -> Page:
    """The booth's display page; every speech report it sends is appended to ``sent``."""
    display = context.new_page()

    def watch(socket: WebSocket) -> None:
        def frame(payload: str | bytes) -> None:
            message = json.loads(payload)
            if message.get("type") == "speech":
                sent.append(message)

        socket.on("framesent", frame)

    display.on("websocket", watch)
    display.goto(live_server.url + display_path(signing_key(app), BOOTH))
    wait_for_js(display, "window.robotDisplay && window.robotDisplay.connected()")
    return display


def open_check(page: Page, live_server: LiveServer, session_id: int) -> None:
    target = f"/booths/{BOOTH}/check?session_id={session_id}"
    page.goto(f"{live_server.url}/login?next={target}")
    page.get_by_label("Username").fill("tech")
    page.get_by_label("Password").fill("correct horse battery")
    page.get_by_role("button", name="Log in").click()
    expect(page.get_by_role("heading", name=f"Booth check: {BOOTH}")).to_be_visible()


@pytest.mark.usefixtures("worker")
def test_the_display_page_in_chromium_voices_the_booth_checks_test_prompt(
    live_server: LiveServer,
    app: FastAPI,
    context: BrowserContext,
    screen_context: BrowserContext,
    engine: Engine,
) -> None:
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2), booth=BOOTH)
    add_user(engine, "tech", "correct horse battery", "wizard")
    reported: list[dict[str, Any]] = []
    open_display(screen_context, live_server, app, reported)  # a window of its own
    check = context.new_page()
    open_check(check, live_server, wizard.session_id)

    check.get_by_role("button", name="Run the check").click()
    speech = check.locator("tr[data-step='speech']")
    expect(speech).to_have_attribute("data-status", "pass", timeout=60_000)
    expect(check.locator("tr[data-step='robot']")).to_have_attribute("data-status", "pass")
    expect(check.locator("#check-robot")).to_have_text("Checked on the display.")
    # The page itself played it: it reported the check's prompt starting and ending.
    assert [m["event"] for m in reported] == ["start", "end"], reported
    assert all(str(m["prompt_id"]).startswith("booth-check:") for m in reported)
    assert reported[1]["reason"] == "ended"


def test_with_the_display_closed_the_speech_step_fails(
    live_server: LiveServer, app: FastAPI, page: Page, engine: Engine, worker: Worker
) -> None:
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2), booth=BOOTH)
    add_user(engine, "tech", "correct horse battery", "wizard")
    open_check(page, live_server, wizard.session_id)
    page.get_by_role("button", name="Run the check").click()
    expect(page.locator("#check-summary")).to_contain_text("NOT READY", timeout=60_000)
    expect(page.locator("tr[data-step='speech']")).to_have_attribute("data-status", "fail")
    expect(page.locator("tr[data-step='robot']")).to_have_attribute("data-status", "fail")
