"""In Chromium: the wizard ends a session early from the console (the phone says thank
you), and a switch to a condition the session already ran asks for a confirmation first."""

from __future__ import annotations

import random

import pytest
from playwright.sync_api import Page, expect

from tests.e2e.wizard.conftest import Console

pytestmark = pytest.mark.browser


def run_interaction_one(console: Console) -> None:
    """Interaction 1 done through the API (the console follows live)."""
    wizard, phone = console.wizard, console.phone
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    phone.rank(random.Random(1))
    wizard.advance(1, "negotiation")
    wizard.negotiate(1, lambda _s: True)
    wizard.advance(1, "questionnaire")
    phone.answer_questionnaires(1, random.Random(1))


def test_the_wizard_ends_a_session_early(console: Console, phone_page: Page) -> None:
    page, phone = console.page, phone_page
    expect(phone.locator("#connection")).to_have_text("Connected")
    page.locator("#primary-action").click()  # start the session
    expect(page.locator("#primary-action")).to_contain_text("Start interaction 1")

    page.get_by_role("button", name="End session early…").click()
    dialog = page.locator("#end-dialog")
    expect(dialog).to_be_visible()
    page.get_by_label("Reason").select_option("other")
    page.get_by_role("button", name="End the session").click()
    expect(page.locator("#flash")).to_contain_text("Say in a few words why")
    assert console.wizard.refresh()["state"] == "running"  # nothing changed

    page.get_by_role("button", name="End session early…").click()
    page.get_by_label("Reason").select_option("technical_failure")
    page.get_by_label('Note (required for "other")').fill("projector broke")
    page.get_by_role("button", name="End the session").click()
    expect(page.locator("#primary-action")).to_have_text("Session ended early")
    expect(page.locator("#primary-action")).to_be_disabled()
    expect(page.get_by_role("button", name="End session early…")).to_be_disabled()
    expect(page.locator("#timeline li[data-kind='session.ended_early']")).to_contain_text(
        "SESSION ENDED EARLY: technical failure (projector broke)"
    )
    expect(phone.get_by_role("heading", name="Thank you!")).to_be_visible()
    snapshot = console.wizard.refresh()
    assert snapshot["state"] == "ended"


def test_a_repeated_condition_is_confirmed_as_a_deviation(console: Console) -> None:
    page = console.page
    run_interaction_one(console)
    expect(page.locator("#primary-action")).to_contain_text("Start interaction 2")
    first = console.wizard.refresh()["interactions"][0]["condition"]
    planned = console.wizard.interaction(2)["planned_condition"]
    page.locator(f"#condition-switch button[data-condition='{first}']").click()
    dialog = page.locator("#confirm-dialog")
    expect(dialog).to_contain_text(f'planned as "{planned}"')
    page.get_by_role("button", name="Switch and log deviation").click()
    # The server refuses a condition already run; the console asks again, in its words.
    expect(dialog).to_be_visible()
    expect(dialog).to_contain_text(f"Interaction 1 already ran {first}")
    assert console.wizard.refresh()["interactions"][1]["condition"] == planned
    page.get_by_role("button", name="Switch and log deviation").click()
    expect(page.locator("#condition-note")).to_contain_text(f"Deviation: running {first}")
    expect(page.locator("#timeline li[data-kind='condition.switched']")).to_contain_text(
        f"confirmed although interaction 1 already ran {first}"
    )
    assert console.wizard.refresh()["interactions"][1]["condition"] == first
