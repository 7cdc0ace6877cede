"""In Chromium, the console on a long lab day: a refusal never covers the primary action
(before the session and in the negotiation, at 1280x720 and 1920x1080) and does not
contradict itself (a late undo), and a finished session turns its prompt buttons off and
says the phone left."""

from __future__ import annotations

import random

import pytest
from playwright.sync_api import Locator, Page, expect

from tests.e2e.wizard.conftest import Console
from tests.support.browser import wait_for_js

pytestmark = pytest.mark.browser


def overlaps(a: Locator, b: Locator) -> bool:
    one, two = a.bounding_box(), b.bounding_box()
    assert one is not None
    assert two is not None
    apart_x = one["x"] + one["width"] <= two["x"] or two["x"] + two["width"] <= one["x"]
    apart_y = one["y"] + one["height"] <= two["y"] or two["y"] + two["height"] <= one["y"]
    return not (apart_x or apart_y)


def into_negotiation(console: Console) -> None:
    wizard = console.wizard
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    console.phone.rank(random.Random(2))
    wizard.advance(1, "negotiation")


@pytest.mark.parametrize("size", [(1280, 720), (1920, 1080)])
def test_a_refusal_shows_below_the_primary_action(console: Console, size: tuple[int, int]) -> None:
    page = console.page
    page.set_viewport_size({"width": size[0], "height": size[1]})
    expect(page.locator("#primary-action")).to_contain_text("Start the session")
    page.locator("#bar-participant").click()
    page.keyboard.press("a")  # accept: nothing to accept before the negotiation
    flash = page.locator("#flash")
    expect(flash).to_contain_text("Cannot accept now. Allowed now: start the session")
    assert not overlaps(flash, page.locator("#primary-action"))
    expect(page.locator("#primary-action")).to_be_visible()


def inside(locator: Locator, size: tuple[int, int]) -> bool:
    box = locator.bounding_box()
    assert box is not None
    return (box["x"] >= 0 and box["y"] >= 0 and box["x"] + box["width"] <= size[0]
            and box["y"] + box["height"] <= size[1])  # fmt: skip


@pytest.mark.parametrize("size", [(1280, 720), (1920, 1080)])
def test_a_refusal_in_the_negotiation_leaves_the_primary_action_uncovered(
    console: Console, size: tuple[int, int]
) -> None:
    """The negotiation is the fullest screen (suggestion, phrasings, replies, ranking): a
    refusal there still shows beside the big button, not over it, on a laptop too."""
    page = console.page
    page.set_viewport_size({"width": size[0], "height": size[1]})
    into_negotiation(console)
    primary = page.locator("#primary-action")
    expect(primary).to_contain_text("Decide suggestion 1")
    page.locator("#bar-participant").click()
    page.keyboard.press("u")  # nothing decided yet: nothing to undo
    flash = page.locator("#flash")
    expect(flash).to_contain_text("Cannot undo now. Allowed now:")
    expect(flash).to_be_visible()
    expect(primary).to_be_visible()
    assert not overlaps(flash, primary)
    assert inside(flash, size), "the refusal is off screen"
    assert inside(primary, size), "the primary action is off screen"
    # The topmost element at the button's centre is the button (nothing drawn over it).
    assert primary.evaluate(
        """(b) => { const r = b.getBoundingClientRect();
                    const top = document.elementFromPoint(r.x + r.width / 2, r.y + r.height / 2);
                    return b.contains(top); }"""
    )


def test_a_late_undo_says_it_is_too_late_and_nothing_else(console: Console, page: Page) -> None:
    into_negotiation(console)
    expect(page.locator("#primary-action")).to_contain_text("Decide suggestion 1")
    page.locator("#bar-participant").click()
    page.keyboard.press("a")
    expect(page.locator("#primary-action")).to_contain_text("Decide suggestion 2")
    undo = next(a for a in console.wizard.refresh()["allowed"] if a["action"] == "undo")
    # The undo window is wall-clock time: wait until the page's clock has passed it.
    wait_for_js(page, f"Date.now() > Date.parse({undo['until']!r})", timeout=30_000)
    page.keyboard.press("u")
    flash = page.locator("#flash")
    expect(flash).to_have_text("Too late to undo suggestion 1: its undo window has passed.")
    page.keyboard.press("d")  # decline 2: the console still works
    expect(page.locator("#primary-action")).to_contain_text("Decide suggestion 3")


def test_a_finished_session_turns_prompts_off_and_the_phone_chip_says_it_left(
    console: Console, phone_page: Page
) -> None:
    page = console.page
    expect(page.locator("#phone-state")).to_have_text("phone connected")
    wizard, phone = console.wizard, console.phone
    wizard.start()
    for position in range(1, wizard.snapshot["interaction_count"] + 1):
        wizard.advance(position, "discussion")
        wizard.advance(position, "ranking")
        phone.rank(random.Random(position))
        wizard.advance(position, "negotiation")
        wizard.negotiate(position, lambda _s: True)
        wizard.advance(position, "questionnaire")
        phone.answer_questionnaires(position, random.Random(position))
    phone.answer_questionnaires(0, random.Random(0))
    expect(page.locator("#primary-action")).to_contain_text("Session complete")
    buttons = page.locator("#prompt-sections button")
    expect(buttons.first).to_be_disabled()
    assert buttons.evaluate_all("(all) => all.every((b) => b.disabled)")
    expect(phone_page.get_by_role("heading", name="Thank you!")).to_be_visible()
    expect(page.locator("#phone-state")).to_have_text("phone left")
    page.locator("#bar-participant").click()
    page.keyboard.press("i")  # a prompt's letter: refused, nothing sent
    expect(page.locator("#flash")).to_have_text("The session is over: prompts are off.")
    assert not [e for e in console.events() if e["kind"] == "prompt.played"]


@pytest.mark.parametrize("size", [(1280, 720), (1920, 1080)])
def test_the_negotiation_fits_a_laptop_screen(
    console: Console, phone_page: Page, size: tuple[int, int]
) -> None:
    """What the wizard needs in the negotiation is on screen without scrolling."""
    page = console.page
    page.set_viewport_size({"width": size[0], "height": size[1]})
    expect(page.locator("#phone-state")).to_have_text("phone connected")
    into_negotiation(console)
    expect(page.locator(".suggestion-now")).to_be_visible()
    needed = {
        "primary action": page.locator("#primary-action"),
        "current suggestion": page.locator(".suggestion-now .suggestion-move"),
        "its phrasings": page.locator("#suggestion-prompts"),
        "accept": page.locator(".suggestion-now button.accept"),
        "decline": page.locator(".suggestion-now button.decline"),
        "replies": page.locator(".pb-section[data-section='replies']"),
        "live ranking": page.locator("#live-ranking"),
    }
    assert page.evaluate("window.scrollY") == 0
    for what, locator in needed.items():
        assert inside(locator, size), f"{what} is outside the {size[0]}x{size[1]} screen"
    # A condition without a natural source says nothing of one (not "null").
    expect(page.locator("#condition-note")).to_contain_text("runs as planned")
    expect(page.locator("#condition-note")).not_to_contain_text("null")
