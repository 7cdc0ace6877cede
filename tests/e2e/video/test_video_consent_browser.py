"""The consent page's video items on a small phone (320x568): two optional boxes under the
study's text, the microphone's disabled until the video's is ticked and cleared with it;
what was ticked is what the session keeps; the page never scrolls sideways."""

from __future__ import annotations

import pytest
from playwright.sync_api import Browser, expect
from sqlalchemy import Engine, select

from chameleons.backend.models import Session as SessionRow
from tests.backend.video.conftest import VIDEO_STUDY
from tests.e2e.phone.test_procedure_browser import fits, small_phone, staff
from tests.support.bots import WizardBot, study_with_plan
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


@pytest.mark.parametrize("sound", [True, False])
def test_the_participant_ticks_what_they_agree_to(
    live_server: LiveServer, browser: Browser, engine: Engine, sound: bool
) -> None:
    pi, _default_study, http = staff(live_server, engine)
    try:
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2, yaml=VIDEO_STUDY))
        context = small_phone(browser, (320, 568))
        page = context.new_page()
        page.goto(live_server.url + wizard.phone_path)
        filmed = page.get_by_label("I agree to be filmed during the conversations")
        voice = page.get_by_label("I agree to my voice being recorded with the video")
        expect(filmed).not_to_be_checked()
        expect(voice).to_be_disabled()
        filmed.check()
        expect(voice).to_be_enabled()
        voice.check()
        filmed.uncheck()  # taking the video back takes the sound with it
        expect(voice).to_be_disabled()
        expect(voice).not_to_be_checked()
        filmed.check()
        if sound:
            voice.check()
        fits(page)
        page.locator("#consent-agree").click()
        expect(page.locator("#consent-agree")).to_have_count(0)
        with engine.connect() as db:
            kept = db.execute(select(SessionRow.video_consent, SessionRow.video_audio_consent)
                              .where(SessionRow.id == wizard.session_id)).one()  # fmt: skip
        assert tuple(kept) == (True, sound)
        context.close()
    finally:
        http.close()
