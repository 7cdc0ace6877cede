"""In Chromium: the wizard writes a note with Shift+N and Enter; it lands on the timeline,
and an empty note is refused without a request."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.e2e.wizard.conftest import Console

pytestmark = pytest.mark.browser


def test_a_note_from_the_keyboard_lands_on_the_timeline(console: Console) -> None:
    page = console.page
    expect(page.locator("#primary-action")).to_be_enabled()
    page.locator("body").click()  # nothing focused: the console's keys are live
    page.keyboard.press("Shift+N")
    note = page.locator("#note-text")
    expect(note).to_be_focused()
    page.keyboard.press("Enter")
    expect(page.locator("#flash")).to_contain_text("Write the note first")
    note.fill("participant laughed at the intro")
    page.keyboard.press("Enter")
    row = page.locator("#timeline li[data-kind='wizard.note']")
    expect(row).to_contain_text("Note: participant laughed at the intro")
    expect(note).to_have_value("")
    stored = [e for e in console.events() if e["kind"] == "wizard.note"]
    assert [e["payload"]["text"] for e in stored] == [  # type: ignore[index]
        "participant laughed at the intro"]
    page.keyboard.press("Escape")  # leaves the field; the keys work again
    expect(note).not_to_be_focused()
