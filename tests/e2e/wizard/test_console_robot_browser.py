"""The console's robot in Chromium, with a real bridge and a real worker:

- a Furhat that refuses the login (the project's Furhat peer, modelled on Furhat's own
  Realtime API client: ``response.auth`` with ``access``) turns the *Robot* chip red with
  the reason; the wizard's "Try the robot again" retries, and once the robot accepts, the
  chip turns green;
- the virtual robot with no display page open: a prompt is NOT VOICED on the console (the
  now-playing line and the timeline) and its button gets no ✓.
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from playwright.sync_api import expect

from chameleons.worker.runtime import Worker, WorkerConfig
from tests.e2e.wizard.conftest import Console
from tests.e2e.wizard.test_console_worker import app  # noqa: F401 - the app with a bridge
from tests.worker.furhat_peer import FurhatPeer

pytestmark = pytest.mark.browser


def start_worker(console: Console, application: FastAPI, tmp_path: Path, **changes: Any) -> Worker:
    bridge = application.state.bridge
    config = WorkerConfig(booth=console.wizard.snapshot["booth"], livelink_port=None,
                          facecapturex_port=None, data_dir=tmp_path,
                          command_endpoint=bridge.command_endpoint,
                          telemetry_endpoint=bridge.telemetry_endpoint,
                          **changes)  # fmt: skip
    running = Worker(config).start()
    deadline = time.monotonic() + 10
    while config.booth not in bridge.workers():  # polls the hello; not a fixed wait
        assert time.monotonic() < deadline, "the worker did not say hello"
        time.sleep(0.02)
    return running


@pytest.fixture
def refusing_robot() -> Iterator[FurhatPeer]:
    with FurhatPeer(access=False) as peer:
        yield peer


def test_a_refused_furhat_login_is_red_with_the_reason_and_try_again_retries(
    console: Console,
    app: FastAPI,  # noqa: F811 - the imported fixture
    tmp_path: Path,
    refusing_robot: FurhatPeer,
) -> None:
    worker = start_worker(console, app, tmp_path, driver="furhat", robot_url=refusing_robot.url,
                          robot_key="wrong")  # fmt: skip
    try:
        page = console.page
        chip = page.locator("#health .chip[data-check='robot']")
        expect(chip).to_have_attribute("data-state", "bad", timeout=20_000)
        expect(chip).to_contain_text("login refused: the robot refused the login")
        expect(page.locator("#health .alarm")).to_contain_text("Robot")
        retry = page.locator("#robot-retry")
        expect(retry).to_have_text("Try the robot again")
        assert refusing_robot.connections == 1  # refused: no retry until the wizard asks
        refusing_robot.access = True  # the lab fixed the robot's key
        retry.click()
        expect(chip).to_have_attribute("data-state", "ok", timeout=20_000)
        expect(chip).to_contain_text("connected")
        expect(page.locator("#robot-retry")).to_have_count(0)
        expect(page.locator("#timeline li[data-kind='robot.retry_requested']")).to_have_count(1)
        assert refusing_robot.connections == 2
    finally:
        worker.stop()


def test_with_no_display_open_a_prompt_is_not_voiced_and_gets_no_tick(
    console: Console,
    app: FastAPI,  # noqa: F811 - the imported fixture
    tmp_path: Path,
) -> None:
    worker = start_worker(console, app, tmp_path, driver="virtual")
    try:
        page = console.page
        chip = page.locator("#health .chip[data-check='robot']")
        expect(chip).to_contain_text("no robot display open", timeout=20_000)
        button = page.locator("button.pb[data-group='ack_yes']")
        button.click()
        played = page.locator("#timeline li[data-kind='prompt.played']")
        expect(played).to_have_count(1)
        # Nobody voices it: after the start timeout the console says so everywhere.
        expect(played.locator(".tl-latency")).to_contain_text("NOT VOICED", timeout=20_000)
        expect(played).to_have_class(re.compile(r"\btl-failed\b"))
        silent = page.locator("#timeline li[data-kind='prompt.not_voiced']")
        expect(silent).to_contain_text("NOT VOICED: no robot display open for booth-1")
        expect(page.locator("#now-playing")).to_contain_text("NOT VOICED")
        # The participant never heard it: no ✓ on its button, which says so instead.
        expect(button.locator(".pb-played")).to_have_text("✗ not voiced")
        expect(button).to_have_class(re.compile(r"\bnot-voiced\b"))
        expect(button).not_to_have_class(re.compile(r"\bplayed\b"))
    finally:
        worker.stop()
