"""The login flow in a real Chromium against a real server."""

from __future__ import annotations

import pytest
from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from tests.backend.test_auth import add_user
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


def test_staff_page_redirects_to_login_when_logged_out(live_server: LiveServer, page: Page) -> None:
    page.goto(live_server.url + "/")
    expect(page).to_have_url(live_server.url + "/login?next=/")
    expect(page.get_by_role("heading", name="Staff login")).to_be_visible()


def test_wrong_password_shows_a_clear_message(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    add_user(engine, "wiz", "right password", "wizard")
    page.goto(live_server.url + "/login")
    page.get_by_label("Username").fill("wiz")
    page.get_by_label("Password").fill("not it")
    page.get_by_role("button", name="Log in").click()
    expect(page.get_by_role("alert")).to_have_text("Wrong username or password.")


def test_login_then_logout(live_server: LiveServer, page: Page, engine: Engine) -> None:
    add_user(engine, "pia", "correct horse", "pi")
    page.goto(live_server.url + "/")
    page.get_by_label("Username").fill("pia")
    page.get_by_label("Password").fill("correct horse")
    page.get_by_role("button", name="Log in").click()
    expect(page.get_by_role("heading", name="Welcome, pia")).to_be_visible()
    page.get_by_role("button", name="Log out").click()
    expect(page.get_by_role("heading", name="Staff login")).to_be_visible()
