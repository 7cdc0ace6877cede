"""The console in Chromium at a booth with both robots (``--driver virtual+furhat``), whose
study has a Furhat condition: while the display runs, a Furhat that refuses the login gets
an amber *Furhat* chip naming the condition that needs it, and "Try the robot again"
retries it; a real bridge, a real worker and the project's Furhat peer."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi import FastAPI
from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from tests.backend.wizard.test_robot_renderer import furhat_study
from tests.e2e.wizard.conftest import Console, log_in
from tests.e2e.wizard.test_console_robot_browser import start_worker
from tests.e2e.wizard.test_console_worker import app  # noqa: F401 - the app with a bridge
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, study_with_plan
from tests.support.live_server import LiveServer
from tests.worker.furhat_peer import FurhatPeer

pytestmark = pytest.mark.browser


@pytest.fixture
def refusing_robot() -> Iterator[FurhatPeer]:
    with FurhatPeer(access=False) as peer:
        yield peer


def test_a_refused_furhat_the_study_needs_is_amber_and_try_again_retries_it(
    live_server: LiveServer,
    staff: StaffApi,
    page: Page,
    engine: Engine,
    app: FastAPI,  # noqa: F811 - the imported fixture
    tmp_path: Path,
    refusing_robot: FurhatPeer,
) -> None:
    wizard = WizardBot.create(staff, study_with_plan(staff, 6, yaml=furhat_study()))
    path = f"/wizard/sessions/{wizard.session_id}"
    log_in(page, live_server.url, engine, path)
    page.wait_for_url(f"**{path}")
    console = Console(live_server, wizard, page, ParticipantBot(staff.http, wizard.token))
    worker = start_worker(console, app, tmp_path, driver="virtual+furhat",
                          robot_url=refusing_robot.url, robot_key="wrong")  # fmt: skip
    try:
        furhat = page.locator("#health .chip[data-check='furhat']")
        expect(furhat).to_have_attribute("data-state", "degraded", timeout=20_000)
        expect(furhat).to_contain_text("Furhat")
        expect(furhat).to_contain_text("login refused: the robot refused the login")
        expect(furhat).to_contain_text("copy_furhat needs it")
        robot = page.locator("#health .chip[data-check='robot']")
        expect(robot).to_contain_text("(the display runs now)")
        retry = page.locator("#robot-retry")
        expect(retry).to_have_text("Try the robot again")
        refusing_robot.access = True  # the lab fixed the robot's key
        retry.click()
        expect(furhat).to_have_attribute("data-state", "ok", timeout=20_000)
        expect(furhat).to_contain_text("connected (for copy_furhat)")
        expect(page.locator("#robot-retry")).to_have_count(0)
    finally:
        worker.stop()
