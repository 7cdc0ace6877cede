"""In Chromium: a console tab open on a participant who is then withdrawn says its session
no longer exists and stops working; the next participant gets a new session id, so the
old tab can never turn into their session (as it silently did when SQLite reused ids)."""

from __future__ import annotations

import pytest
from playwright.sync_api import Route, expect

from tests.e2e.wizard.conftest import Console
from tests.support.bots import StaffApi, WizardBot

pytestmark = pytest.mark.browser


def test_an_open_console_says_its_withdrawn_session_is_gone(
    console: Console, staff: StaffApi
) -> None:
    page = console.page
    expect(page.locator("#primary-action")).to_be_enabled()
    snapshot = console.wizard.refresh()
    code, study = snapshot["participant"]["code"], snapshot["study_id"]
    expect(page.locator("#console")).to_contain_text(code)

    staff.post(f"/api/pi/participants/{code}/withdraw?study={study}", {"confirm": code})
    banner = page.locator("#conn-banner")
    expect(banner).to_contain_text("This session no longer exists")
    expect(banner).to_contain_text("withdrawn")
    expect(page.locator("#primary-action")).to_be_disabled()
    expect(page.get_by_role("button", name="End session early…")).to_be_disabled()

    newcomer = WizardBot.create(staff, study)
    assert newcomer.session_id > console.wizard.session_id
    new_code = newcomer.refresh()["participant"]["code"]
    assert new_code != code
    page.reload()  # a reopened tab asks the server again: still gone, not the newcomer's
    expect(page.locator("#console")).not_to_be_attached()
    expect(page.locator("body")).not_to_contain_text(new_code)


def test_a_console_still_loading_its_prompts_stays_off_once_its_session_is_gone(
    console: Console, staff: StaffApi
) -> None:
    """The console loads its prompts before it renders: a withdrawal that lands while they
    load must not be undone by that render (CI saw the primary action enabled again)."""
    page = console.page
    expect(page.locator("#primary-action")).to_be_enabled()
    snapshot = console.wizard.refresh()
    code, study = snapshot["participant"]["code"], snapshot["study_id"]
    held: list[Route] = []

    def hold(route: Route) -> None:
        held.append(route)

    page.route("**/prompts?position=*", hold)
    with page.expect_request(lambda request: "/prompts?position=" in request.url):
        page.reload()

    staff.post(f"/api/pi/participants/{code}/withdraw?study={study}", {"confirm": code})
    expect(page.locator("#conn-banner")).to_contain_text("This session no longer exists")
    assert len(held) == 1
    held[0].continue_()
    expect(page.locator("#prompt-sections")).to_contain_text("cannot be shown")
    expect(page.locator("#primary-action")).to_be_disabled()
    expect(page.get_by_role("button", name="End session early…")).to_be_disabled()
