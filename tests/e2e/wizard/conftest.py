"""A live server with the default study, a session, a logged-in wizard page and the phone."""

from __future__ import annotations

import random
from collections.abc import Iterator
from dataclasses import dataclass

import httpx
import pytest
from playwright.sync_api import BrowserContext, Page
from sqlalchemy import Engine

from tests.backend.test_auth import add_user
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, staff_api, study_with_plan
from tests.support.browser import ACTION_TIMEOUT_MS
from tests.support.live_server import LiveServer

PASSWORD = "the wizard's password"


@dataclass
class Console:
    server: LiveServer
    wizard: WizardBot
    page: Page
    phone: ParticipantBot

    @property
    def url(self) -> str:
        return f"{self.server.url}/wizard/sessions/{self.wizard.session_id}"

    def events(self) -> list[dict[str, object]]:
        result: list[dict[str, object]] = self.wizard.staff.get(
            f"/api/sessions/{self.wizard.session_id}/events?limit=5000"
        )
        return result


@pytest.fixture
def http(live_server: LiveServer) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=live_server.url, timeout=10) as client:
        yield client


@pytest.fixture
def staff(http: httpx.Client, engine: Engine) -> StaffApi:
    return staff_api(http, engine, "pi")


def log_in(page: Page, base: str, engine: Engine, next_path: str) -> None:
    add_user(engine, "wiz", PASSWORD, "wizard")
    page.goto(f"{base}/login?next={next_path}")
    page.get_by_label("Username").fill("wiz")
    page.get_by_label("Password").fill(PASSWORD)
    page.get_by_role("button", name="Log in").click()


@pytest.fixture
def console(
    live_server: LiveServer, staff: StaffApi, page: Page, engine: Engine, http: httpx.Client
) -> Console:
    wizard = WizardBot.create(staff, study_with_plan(staff, participants=2))
    phone = ParticipantBot(http, wizard.token)
    phone.prepare(random.Random(wizard.session_id))  # consent and the questions before
    path = f"/wizard/sessions/{wizard.session_id}"
    log_in(page, live_server.url, engine, path)
    page.wait_for_url(f"**{path}")
    return Console(live_server, wizard, page, phone)


@pytest.fixture
def phone_page(phone_context: BrowserContext, console: Console) -> Page:
    page = phone_context.new_page()
    page.set_default_timeout(ACTION_TIMEOUT_MS)
    page.goto(console.server.url + console.wizard.phone_path)
    return page
