"""The booth check page offers the webcam's capture link with a QR code that loads under
the site's Content-Security-Policy, and the link opens the capture page."""

from __future__ import annotations

from fastapi import FastAPI
from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from chameleons.backend.capture import current_capture_path
from tests.backend.test_auth import add_user
from tests.support.browser import wait_for_js
from tests.support.live_server import LiveServer


def test_the_booth_check_shows_the_capture_link_and_its_qr_code(
    live_server: LiveServer, page: Page, engine: Engine, app: FastAPI
) -> None:
    add_user(engine, "tech", "correct horse battery", "wizard")
    page.goto(f"{live_server.url}/login?next=/booths/booth-1/check")
    page.get_by_label("Username").fill("tech")
    page.get_by_label("Password").fill("correct horse battery")
    page.get_by_role("button", name="Log in").click()
    expect(page.get_by_role("heading", name="Booth check: booth-1")).to_be_visible()
    page.get_by_text("No iPhone? Use a webcam").click()
    qr = page.locator("#capture-qr")
    expect(qr).to_be_visible()
    wait_for_js(page, "document.querySelector('#capture-qr').naturalWidth > 0")
    link = page.locator("#capture-link")
    expect(link).to_have_attribute(
        "href", f"{live_server.url}{current_capture_path(app, 'booth-1')}"
    )
    link.click()
    expect(page.get_by_role("heading", name="Webcam capture: booth-1")).to_be_visible()
