"""The phone, in Chromium, with an answer the database cannot store (a NUL character, as a
paste from another app can carry) waiting in its outbox: it sends it once, shows the
server's sentence, drops it from the outbox and does not retry; on PostgreSQL this used to
be a 500 and an endless "Reconnecting…" loop. The sentence is in the session's language
(the script asks for it). Both databases."""

from __future__ import annotations

import httpx
import pytest
from playwright.sync_api import BrowserContext, Request, expect
from sqlalchemy import Engine

from chameleons.backend.input_guard import NUL_IN_TEXT
from chameleons.i18n import gettext
from tests.support.bots import WizardBot, staff_api, study_with_plan
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser

OUTBOX_WITH_A_NUL = """token => localStorage.setItem(`mc:${token}:outbox`, JSON.stringify([{
  target: "questionnaire:-1:about_you", kind: "questionnaire", draft: null,
  body: { client_id: "nulnulnul0123456", position: -1, questionnaire: "about_you",
          answers: { comment: "pasted\\u0000text" } } }]))"""


@pytest.mark.parametrize("language", ["en", "sv"])
def test_the_phone_shows_the_refusal_once_and_does_not_retry(
    live_server: LiveServer, phone_context: BrowserContext, engine: Engine, language: str
) -> None:
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        study = study_with_plan(pi, participants=2)
        wizard = WizardBot.create(pi, study, language=language)
    posts: list[Request] = []
    page = phone_context.new_page()
    page.on("request", lambda r: posts.append(r) if r.method == "POST" else None)
    page.goto(live_server.url + wizard.phone_path)
    expect(page.locator("#app")).to_have_attribute("data-view", "consent")
    # The first page flushes its outbox when its socket opens: wait for that, or it can
    # send the planted answer itself just before the reload (seen in CI on PostgreSQL).
    expect(page.locator("#connection")).to_have_attribute("data-state", "online")
    page.evaluate(OUTBOX_WITH_A_NUL, wizard.token)

    with page.expect_response(lambda r: r.url.endswith("/questionnaire")) as answered:
        page.reload()
    assert answered.value.status == 422
    sentence = gettext(language, NUL_IN_TEXT)
    assert (sentence == NUL_IN_TEXT) == (language == "en")
    expect(page.locator("#error")).to_have_text(sentence)
    expect(page.locator("#error")).to_be_visible()
    outbox = page.evaluate("token => localStorage.getItem(`mc:${token}:outbox`)", wizard.token)
    assert outbox == "[]"  # nothing left to retry
    expect(page.locator("#save-status")).not_to_have_attribute("data-state", "offline")
    # The page's socket is up and the outbox flushes on every reconnect: still one POST.
    expect(page.locator("#connection")).to_have_attribute("data-state", "online")
    assert [r.url for r in posts if r.url.endswith("/questionnaire")] == [answered.value.url]
    page.close()
