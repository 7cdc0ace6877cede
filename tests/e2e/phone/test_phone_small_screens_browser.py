"""The phone as a participant meets it on the smallest screens (issue 28): item names wrap
between words, never inside one ("solglasögo-n" at 320 px); "Saved" appears only after the
participant saved something on the page; and the page before the first interaction says
the first conversation begins, not "the next"."""

from __future__ import annotations

import random
from collections.abc import Iterator

import httpx
import pytest
from playwright.sync_api import Browser, BrowserContext, Page, expect
from sqlalchemy import Engine

from chameleons.i18n import script_catalogue
from tests.support.bots import ParticipantBot, WizardBot, staff_api, study_with_plan
from tests.support.browser import ACTION_TIMEOUT_MS
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser

# The words of the item names broken across lines (a word after a hyphen counts on its own:
# "receiver-" / "transmitter" is a break a reader expects).
WORDS_SPLIT = """(list) => {
  const broken = [];
  for (const name of list.querySelectorAll(".name")) {
    const text = name.firstChild;
    const words = [...text.data.matchAll(/[^\\s-]+-?/g)];  // a break after "-" is fine
    for (const word of words) {
      const range = document.createRange();
      range.setStart(text, word.index);
      range.setEnd(text, word.index + word[0].length);
      const lines = new Set([...range.getClientRects()].map((r) => Math.round(r.top)));
      if (lines.size > 1) broken.push(word[0]);
    }
  }
  return broken;
}"""


@pytest.fixture
def narrow(browser: Browser) -> Iterator[BrowserContext]:
    """The narrowest phone still sold (320 px), touch, a mobile user agent."""
    context = browser.new_context(
        viewport={"width": 320, "height": 640}, has_touch=True, is_mobile=True,
        device_scale_factor=2,
    )  # fmt: skip
    yield context
    context.close()


def open_phone(context: BrowserContext, url: str) -> Page:
    page = context.new_page()
    page.set_default_timeout(ACTION_TIMEOUT_MS)
    page.goto(url)
    return page


@pytest.mark.parametrize(
    ("language", "width"), [("sv", 320), ("en", 320), ("sv", 390)], ids=lambda v: str(v)
)
def test_item_names_wrap_between_words_on_small_phones(
    live_server: LiveServer, browser: Browser, engine: Engine, language: str, width: int
) -> None:
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2))
        phone = ParticipantBot(http, wizard.token)
        phone.choose_language(language)
        rng = random.Random(7)
        phone.prepare(rng)
        wizard.start()
        context = browser.new_context(viewport={"width": width, "height": 740},
                                      has_touch=True, is_mobile=True)  # fmt: skip
        page = open_phone(context, live_server.url + wizard.phone_path)
        for position in (1, 2, 3):
            wizard.advance(position, "discussion")
            wizard.advance(position, "ranking")
            expect(page.locator("#app")).to_have_attribute("data-view", "ranking")
            ranking = page.locator("#ranking-list")
            expect(ranking.locator("li")).to_have_count(5)
            assert ranking.evaluate(WORDS_SPLIT) == [], f"interaction {position}"
            # Nothing sticks out sideways either.
            assert page.evaluate("document.documentElement.scrollWidth") <= width
            phone.rank(rng)
            wizard.advance(position, "negotiation")
            expect(page.locator("#app")).to_have_attribute("data-view", "ranked")
            assert page.locator("#current-ranking").evaluate(WORDS_SPLIT) == []
            wizard.negotiate(position, lambda _suggestion: True)
            wizard.advance(position, "questionnaire")
            phone.answer_questionnaires(position, rng)
        context.close()


def test_saved_says_what_was_saved_and_goes_when_the_page_changes(
    live_server: LiveServer, narrow: BrowserContext, engine: Engine
) -> None:
    """A bare "Saved ✓" on the page after the consent read as if that page, still empty,
    were saved already."""
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2))
    page = open_phone(narrow, live_server.url + wizard.phone_path)
    status = page.locator("#save-status")
    expect(page.locator("#app")).to_have_attribute("data-view", "consent")
    expect(status).to_have_text("")
    page.locator("#consent-agree").click()
    expect(page.locator("form#questionnaire")).to_be_visible()
    expect(status).to_have_text("Consent saved ✓")
    page.locator("fieldset.question").first.locator("label.choice").first.click()
    expect(status).to_have_text("")  # this page's answer is not saved yet
    page.get_by_role("button", name="Save").click()
    expect(page.get_by_role("heading", name="Welcome!")).to_be_visible()
    expect(status).to_have_text("Answers saved ✓")


def test_the_page_before_the_first_interaction_says_the_first_conversation_begins(
    live_server: LiveServer, phone_context: BrowserContext, engine: Engine
) -> None:
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2))
        phone = ParticipantBot(http, wizard.token)
        rng = random.Random(3)
        phone.prepare(rng)
        page = open_phone(phone_context, live_server.url + wizard.phone_path)
        lead = page.locator("#app .lead")
        expect(lead).to_have_text("Thank you for taking part. The session begins shortly.")
        wizard.start()  # interaction 1 is not running yet: there was no conversation before
        expect(lead).to_have_text("The first conversation begins shortly.")
        wizard.advance(1, "discussion")
        expect(page.locator("#app")).to_have_attribute("data-view", "listen")
        wizard.advance(1, "ranking")
        phone.rank(rng)
        wizard.advance(1, "negotiation")
        wizard.negotiate(1, lambda _suggestion: False)
        wizard.advance(1, "questionnaire")
        phone.answer_questionnaires(1, rng)
        expect(lead).to_have_text("The next conversation begins shortly.")


def test_the_swedish_phone_says_the_first_conversation_too() -> None:
    swedish = script_catalogue("sv")
    assert swedish["The first conversation begins shortly."] == "Det första samtalet börjar strax."
    assert swedish["Consent saved ✓"] == "Samtycket är sparat ✓"
