"""In Chromium: the wizard pauses a session with a reason (the phone shows a short pause
and holds the ranking sent meanwhile; prompts are off) and resumes it (the held ranking
goes through; the timeline says how long the pause lasted)."""

from __future__ import annotations

import pytest
from playwright.sync_api import Page, WebSocketRoute, expect

from tests.e2e.wizard.conftest import Console

pytestmark = pytest.mark.browser


def test_the_wizard_pauses_and_resumes(console: Console, phone_page: Page) -> None:
    page, phone, wizard = console.page, phone_page, console.wizard
    expect(phone.locator("#connection")).to_have_text("Connected")
    expect(page.get_by_role("button", name="Pause…")).to_be_disabled()  # not started yet
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    expect(phone.locator("#app")).to_have_attribute("data-view", "ranking")

    page.get_by_role("button", name="Pause…").click()
    expect(page.locator("#pause-dialog")).to_be_visible()
    page.get_by_label("Why pause").select_option("other")
    page.get_by_role("button", name="Pause the session").click()
    expect(page.locator("#flash")).to_contain_text("Say in a few words why the session pauses")
    assert wizard.refresh()["paused"] is None  # nothing changed

    page.get_by_role("button", name="Pause…").click()
    page.get_by_label("Why pause").select_option("participant_break")
    page.get_by_label('Note on the pause (required for "other")').fill("needs water")
    page.get_by_role("button", name="Pause the session").click()
    expect(page.locator("#primary-action")).to_contain_text("Resume the session")
    expect(page.locator("#pause-banner")).to_contain_text(
        "the participant needed a break (needs water)"
    )
    expect(page.locator("#timeline li[data-kind='session.paused']")).to_contain_text(
        "SESSION PAUSED: the participant needed a break (needs water), during interaction 1"
    )
    expect(phone.get_by_role("heading", name="A short pause")).to_be_visible()
    prompt = page.locator("#prompt-sections button").first
    expect(prompt).to_be_disabled()
    expect(page.locator("#say-button")).to_be_disabled()
    expect(page.get_by_role("button", name="Pause…")).to_be_disabled()

    page.locator("#primary-action").click()  # resume
    expect(page.locator("#pause-banner")).to_be_hidden()
    expect(page.locator("#timeline li[data-kind='session.resumed']")).to_contain_text(
        "Session resumed after"
    )
    expect(prompt).to_be_enabled()
    expect(phone.locator("#app")).to_have_attribute("data-view", "ranking")
    snapshot = wizard.refresh()
    assert snapshot["pause_count"] == 1
    assert snapshot["paused_seconds"] > 0


def test_a_ranking_sent_during_a_pause_is_held_until_it_continues(
    console: Console, phone_page: Page
) -> None:
    page, phone, wizard = console.page, phone_page, console.wizard
    # The phone's live updates pass through here, so the test can hold them back: the
    # phone then sends its ranking without knowing the session was paused meanwhile.
    held = {"on": False}

    def relay(socket: WebSocketRoute) -> None:
        server = socket.connect_to_server()
        server.on_message(lambda message: None if held["on"] else socket.send(message))

    phone.route_web_socket("**/ws/p/**", relay)
    phone.reload()
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    expect(phone.locator("#app")).to_have_attribute("data-view", "ranking")

    held["on"] = True
    wizard.staff.post(f"/api/sessions/{wizard.session_id}/pause", {"reason": "interruption"})
    expect(page.locator("#primary-action")).to_contain_text("Resume the session")
    phone.locator("#submit-ranking").click()
    # Refused with a sentence; the phone learns of the pause and keeps the ranking.
    expect(phone.get_by_role("heading", name="A short pause")).to_be_visible()
    expect(phone.locator("#save-status")).to_have_text(
        "Kept on this phone \u2013 sent as soon as the session continues."
    )
    assert wizard.refresh()["interactions"][0]["initial_ranking"] is None

    held["on"] = False
    page.locator("#primary-action").click()  # resume
    expect(phone.locator("#save-status")).to_have_text("Ranking saved ✓")
    expect(phone.locator("#app")).to_have_attribute("data-view", "ranked")
    assert wizard.refresh()["interactions"][0]["initial_ranking"] is not None
