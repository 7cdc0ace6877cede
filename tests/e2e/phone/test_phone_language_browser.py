"""The phone's language buttons before consent, in Chromium: the participant registered in
English switches to Swedish on the first page, and the consent page (the study's texts and
the phone's own) comes back in Swedish; the wizard sees the change; after consent the
buttons are gone."""

from __future__ import annotations

import httpx
import pytest
from playwright.sync_api import BrowserContext, expect
from sqlalchemy import Engine

from chameleons.experiment.study import load_default_study
from chameleons.i18n import script_catalogue
from tests.support.bots import WizardBot, staff_api, study_with_plan
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


def test_choosing_swedish_before_consent_shows_the_consent_page_in_swedish(
    live_server: LiveServer, phone_context: BrowserContext, engine: Engine
) -> None:
    study = load_default_study()
    english, swedish = study.procedure.consent, study.in_language("sv").procedure.consent
    assert english is not None
    assert swedish is not None
    assert swedish.title != english.title
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2))
        page = phone_context.new_page()
        page.goto(live_server.url + wizard.phone_path)
        expect(page.locator("#app")).to_have_attribute("data-view", "consent")
        expect(page.locator("html")).to_have_attribute("lang", "en")
        expect(page.locator("#app h1")).to_have_text(english.title)
        expect(page.locator("#consent-agree")).to_have_text(english.agree)
        chooser = page.get_by_role("navigation", name="Choose your language")
        expect(chooser.locator("[data-language=en]")).to_have_attribute("aria-pressed", "true")

        chooser.locator("[data-language=sv]").click()
        expect(page.locator("html")).to_have_attribute("lang", "sv")
        expect(page.locator("#app h1")).to_have_text(swedish.title)
        expect(page.locator("#consent-agree")).to_have_text(swedish.agree)
        chooser = page.get_by_role(
            "navigation", name=script_catalogue("sv")["Choose your language"]
        )
        expect(chooser.locator("[data-language=sv]")).to_have_attribute("aria-pressed", "true")
        assert wizard.refresh()["language"] == "sv"

        page.locator("#consent-agree").click()
        expect(page.locator("form#questionnaire")).to_be_visible()
        expect(page.locator("nav.languages")).to_have_count(0)
        page.close()
