"""In Chromium: the participant's link opened on two phones shows as two on the console,
with a warning; the wizard disconnects the later one, which says the link is open on
another phone and stays away after a reload, while the first phone goes on."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from playwright.sync_api import Browser, BrowserContext, Page, expect

from tests.e2e.wizard.conftest import Console
from tests.support.bots import ApiError
from tests.support.browser import ACTION_TIMEOUT_MS

pytestmark = pytest.mark.browser


@pytest.fixture
def second_phone(browser: Browser) -> Iterator[BrowserContext]:
    """Another phone: a browser context of its own (its own storage, its own device id)."""
    context = browser.new_context(viewport={"width": 390, "height": 844}, is_mobile=True)
    yield context
    context.close()


def test_two_phones_on_one_link_and_the_extra_one_is_sent_away(
    console: Console, phone_page: Page, second_phone: BrowserContext
) -> None:
    page = console.page
    chip = page.locator("#phone-state")
    expect(phone_page.locator("#connection")).to_have_text("Connected")
    expect(chip).to_have_text("phone connected")
    expect(page.locator("#phone-devices")).to_be_hidden()

    extra = second_phone.new_page()
    extra.set_default_timeout(ACTION_TIMEOUT_MS)
    extra.goto(console.server.url + console.wizard.phone_path)
    expect(extra.locator("#connection")).to_have_text("Connected")
    expect(chip).to_have_text("2 phones on this link")
    expect(chip).to_have_class("pill warn")
    rows = page.locator("#phone-devices li")
    expect(rows).to_have_count(2)
    expect(rows.nth(0)).to_contain_text("Phone 1")
    expect(rows.nth(1)).to_contain_text("Phone 2")
    expect(rows.nth(1)).to_contain_text("(later)")
    expect(page.locator("#timeline li[data-kind='phone.connected']").first).to_contain_text(
        "2 phones on this link now"
    )

    # A wrong click costs a phone: the wizard confirms which one, and may think again.
    rows.nth(1).get_by_role("button", name="Disconnect").click()
    dialog = page.locator("#confirm-dialog")
    expect(dialog).to_be_visible()
    expect(dialog.get_by_role("heading")).to_have_text("Disconnect phone 2?")
    dialog.get_by_role("button", name="Cancel").click()
    expect(dialog).to_be_hidden()
    expect(chip).to_have_text("2 phones on this link")
    assert not [e for e in console.events() if e["kind"] == "phone.sent_away"]
    rows.nth(1).get_by_role("button", name="Disconnect").click()
    dialog.get_by_role("button", name="Disconnect phone 2").click()
    expect(extra.get_by_role("heading", name="This link is open on another phone")).to_be_visible()
    expect(chip).to_have_text("phone connected")
    expect(page.locator("#phone-devices")).to_be_hidden()
    expect(page.locator("#timeline li[data-kind='phone.sent_away']")).to_contain_text(
        "Wizard disconnected phone 2"
    )

    extra.reload()  # the same phone again: still sent away while the first holds the link
    expect(extra.get_by_role("heading", name="This link is open on another phone")).to_be_visible()
    expect(chip).to_have_text("phone connected")

    # The first phone goes on: the session starts and it shows the next page.
    page.locator("#primary-action").click()
    expect(page.locator("#primary-action")).to_contain_text("Start interaction 1")
    expect(phone_page.locator("#connection")).to_have_text("Connected")
    sent_away = [e for e in console.events() if e["kind"] == "phone.sent_away"]
    assert len(sent_away) == 1


def test_the_wizard_may_send_the_first_phone_away_instead(
    console: Console, phone_page: Page, second_phone: BrowserContext
) -> None:
    page = console.page
    expect(phone_page.locator("#connection")).to_have_text("Connected")
    extra = second_phone.new_page()
    extra.goto(console.server.url + console.wizard.phone_path)
    rows = page.locator("#phone-devices li")
    expect(rows).to_have_count(2)
    rows.nth(0).get_by_role("button", name="Disconnect").click()
    page.locator("#confirm-dialog").get_by_role("button", name="Disconnect phone 1").click()
    away = phone_page.get_by_role("heading", name="This link is open on another phone")
    expect(away).to_be_visible()
    expect(extra.locator("#connection")).to_have_text("Connected")
    expect(page.locator("#phone-state")).to_have_text("phone connected")
    # The one phone left cannot be sent away: the participant would have none.
    phones = console.wizard.refresh()["phone"]["devices"]
    assert len(phones) == 1
    with pytest.raises(ApiError) as refused:
        console.wizard.staff.post(
            f"/api/sessions/{console.wizard.session_id}/phones/{phones[0]['id']}/disconnect"
        )
    assert refused.value.status == 409
    assert "Only one phone is on this link" in str(refused.value.detail)
    expect(extra.locator("#connection")).to_have_text("Connected")
