"""In Chromium: the wizard writes a note with Shift+N and Enter; it lands on the timeline,
and an empty note is refused without a request."""

from __future__ import annotations

import random

import pytest
from playwright.sync_api import expect
from sqlalchemy import Engine

from tests.backend.test_auth import add_user
from tests.e2e.wizard.conftest import Console

pytestmark = pytest.mark.browser


def test_a_note_from_the_keyboard_lands_on_the_timeline(console: Console) -> None:
    page = console.page
    expect(page.locator("#primary-action")).to_be_enabled()
    page.locator("#bar-participant").click()  # nothing focused: the console's keys are live
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
        "participant laughed at the intro"
    ]
    page.keyboard.press("Escape")  # leaves the field; the keys work again
    expect(note).not_to_be_focused()


def test_timelines_filter_and_the_pi_reads_the_same_sentences(
    console: Console, engine: Engine
) -> None:
    page, wizard, phone = console.page, console.wizard, console.phone
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    phone.rank(random.Random(3))
    ranking = phone.sent[-1]["ranking"]
    wizard.staff.post(f"/api/sessions/{wizard.session_id}/notes", {"text": "hesitated long"})
    expect(page.locator("#timeline li[data-kind='wizard.note']")).to_be_visible()
    notes = page.locator("#timeline-filter").get_by_role("button", name="Notes")
    notes.click()
    expect(notes).to_have_attribute("aria-pressed", "true")
    expect(page.locator("#timeline li:visible")).to_have_count(1)
    expect(page.locator("#timeline li:visible")).to_contain_text("Note: hesitated long")
    page.locator("#timeline-filter").get_by_role("button", name="Phone").click()
    expect(page.locator("#timeline li[data-kind='ranking.submitted']")).to_be_visible()
    expect(page.locator("#timeline li[data-kind='wizard.note']")).to_be_hidden()

    add_user(engine, "pia", "correct horse battery", "pi")
    browser = page.context.browser
    assert browser is not None
    pi = browser.new_context().new_page()
    pi.goto(f"{console.server.url}/login?next=/pi/sessions/{wizard.session_id}")
    pi.get_by_label("Username").fill("pia")
    pi.get_by_label("Password").fill("correct horse battery")
    pi.get_by_role("button", name="Log in").click()
    timeline = pi.locator("#timeline")
    # Items by their names, as the console says it, not by their ids.
    first_name = timeline.locator("li[data-kind='ranking.submitted'] .tl-text")
    expect(first_name).to_contain_text("Phone: ranking submitted — 1. ")
    assert f"1. {ranking[0]}  2." not in first_name.inner_text()  # the id would read so
    expect(timeline.locator("li[data-kind='wizard.note'] .tl-text")).to_have_text(
        "Note: hesitated long"
    )
    pi.locator("#timeline-filter").get_by_role("button", name="Notes").click()
    expect(timeline.locator("li:visible")).to_have_count(1)
    pi.context.close()
