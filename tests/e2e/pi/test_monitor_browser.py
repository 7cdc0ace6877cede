"""In Chromium: the PI's booths monitor shows two booths live (a running session whose phone
and worker are gone is an alarm; a booth waiting for its participant only warns), follows
the wizard's steps within its one-second refresh, and is for PIs only."""

from __future__ import annotations

import httpx
import pytest
from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from tests.backend.test_auth import add_user
from tests.support.bots import WizardBot, staff_api, study_with_plan
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


def test_the_monitor_shows_booths_live_with_alarms(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    http = httpx.Client(base_url=live_server.url, timeout=30)
    pi = staff_api(http, engine, "pi")
    study_id = study_with_plan(pi, participants=4)
    first = WizardBot.create(pi, study_id, booth="booth-1")
    first.start()
    WizardBot.create(pi, study_id, booth="booth-2")
    add_user(engine, "pia", "correct horse battery", "pi")
    page.goto(f"{live_server.url}/login?next=/pi/monitor")
    page.get_by_label("Username").fill("pia")
    page.get_by_label("Password").fill("correct horse battery")
    page.get_by_role("button", name="Log in").click()
    expect(page.get_by_role("heading", name="Booths")).to_be_visible()

    one, two = page.locator("[data-booth='booth-1']"), page.locator("[data-booth='booth-2']")
    expect(one).to_have_class("booth alarm")
    expect(one.locator(".problems")).to_contain_text("Phone: not connected during the session")
    expect(one.locator(".problems")).to_contain_text("Worker")
    expect(two).to_have_class("booth warn")  # waiting for its participant: no alarm
    expect(page.locator("#monitor-alarms")).to_have_text("1 alarm")
    expect(one.locator(".who")).to_contain_text("running")
    # The booth check of each booth, for its open session (after the page's own redraw).
    check = one.locator("a.booth-check-link")
    expect(check).to_have_attribute("href", f"/booths/booth-1/check?session_id={first.session_id}")
    check.click()
    expect(page.get_by_role("heading", name="Booth check: booth-1")).to_be_visible()
    expect(page.locator("#booth-check")).to_contain_text(f"For session {first.session_id}")
    page.go_back()

    first.advance(1, "discussion")  # the page follows without a reload
    expect(one.locator(".who")).to_contain_text("interaction 1 · discussion")
    expect(one.locator(".recent li").first).to_contain_text("Interaction 1: pending → discussion")
    WizardBot.create(pi, study_id, booth="booth-3")
    expect(page.locator("[data-booth='booth-3']")).to_be_visible()
    expect(page.locator(".booth")).to_have_count(3)

    wizard = staff_api(http, engine, "wizard", name="just-a-wizard")
    assert wizard.http.get("/api/pi/monitor").status_code == 403
    http.close()
