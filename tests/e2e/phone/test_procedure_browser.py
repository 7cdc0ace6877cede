"""The procedure on a small phone (390x844 and 320x568): the consent page comes first and
the session cannot start before it; the questions about the participant can all be
skipped and survive a reload; declining ends the session politely with nothing kept; the
final questionnaire's manipulation check names a robot; the debriefing comes last and
survives a reload."""

from __future__ import annotations

import random
import re
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from playwright.sync_api import Browser, BrowserContext, Page, expect
from sqlalchemy import Engine, select

from chameleons.backend.db import build_sessionmaker
from chameleons.backend.models import Event, Participant, QuestionnaireResponse
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.sessions.bot import ApiError, ParticipantBot
from tests.support.bots import PASSWORD, StaffApi, WizardBot, add_staff, study_with_plan
from tests.support.browser import ACTION_TIMEOUT_MS
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser
SAVE = re.compile(r"^Save")
SIZES = [(390, 844), (320, 568)]


@pytest.fixture
def server(app: Any) -> Iterator[LiveServer]:
    live = LiveServer(app).start()
    yield live
    live.stop()


def small_phone(browser: Browser, size: tuple[int, int]) -> BrowserContext:
    width, height = size
    return browser.new_context(
        viewport={"width": width, "height": height},
        has_touch=True,
        is_mobile=True,
        device_scale_factor=2,
    )


def fits(page: Page) -> None:
    """No sideways scrolling; the buttons are at least 44 px high (touch targets)."""
    assert page.evaluate("document.documentElement.scrollWidth - window.innerWidth") <= 0
    for button in page.locator("button.big").all():
        box = button.bounding_box()
        assert box is not None
        assert box["height"] >= 44


def staff(server: LiveServer, engine: Engine) -> tuple[StaffApi, int, httpx.Client]:
    add_staff(engine, "pia", "pi")
    http = httpx.Client(
        base_url=server.url, timeout=60, limits=httpx.Limits(max_keepalive_connections=0)
    )
    pi = StaffApi(http).login("pia", PASSWORD)
    return pi, study_with_plan(pi), http


def rows(engine: Engine, model: Any, **where: Any) -> list[Any]:
    with build_sessionmaker(engine)() as db:
        return list(db.scalars(select(model).filter_by(**where)))


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_consent_then_skippable_questions_then_the_session_and_a_debriefing(
    browser: Browser, server: LiveServer, engine: Engine, size: tuple[int, int]
) -> None:
    pi, study_id, http = staff(server, engine)
    wizard = WizardBot.create(pi, study_id)
    context = small_phone(browser, size)
    page = context.new_page()
    page.set_default_timeout(ACTION_TIMEOUT_MS)
    page.goto(server.url + wizard.phone_path)
    expect(page.get_by_role("heading", name="Before we begin")).to_be_visible()
    expect(page.get_by_text("Taking part is voluntary.", exact=False)).to_be_visible()
    fits(page)
    with pytest.raises(ApiError) as refused:  # the wizard cannot start before consent
        wizard.start(prepare=False)
    assert refused.value.status == 409
    assert "before the participant has given consent" in str(refused.value.detail)
    assert wizard.refresh()["allowed"] == [{"action": "wait", "for": "consent"}]

    page.get_by_role("button", name="I agree to take part").click()
    expect(page.get_by_role("heading", name="About you")).to_be_visible()
    fits(page)
    assert rows(engine, SessionRow, id=wizard.session_id)[0].consent_at is not None
    # An answer survives a reload; the others are skipped (all optional).
    page.get_by_role("radio", name="25-34").check()
    page.reload()
    expect(page.get_by_role("heading", name="About you")).to_be_visible()
    expect(page.get_by_role("radio", name="25-34")).to_be_checked()
    page.get_by_role("button", name=SAVE).click()
    expect(page.get_by_role("heading", name="Welcome!")).to_be_visible()
    answers = {r.item: (r.text, r.skipped) for r in rows(engine, QuestionnaireResponse)}
    assert answers == {
        "age_band": ("age_25_34", False),
        "gender": (None, True),
        "robot_experience": (None, True),
    }

    participant = ParticipantBot(http, wizard.token)
    wizard.start(prepare=False)
    rng = random.Random(5)
    for position in range(1, 4):
        for step in ("discussion", "ranking"):
            wizard.advance(position, step)
        participant.rank(rng)
        wizard.advance(position, "negotiation")
        wizard.negotiate(position, lambda _s: True)
        wizard.advance(position, "questionnaire")
        participant.answer_questionnaires(position, rng)
    expect(page.get_by_role("heading", name="Final questions")).to_be_visible()
    fits(page)
    robots = [wizard.interaction(p)["robot_name"] for p in (1, 2, 3)]
    question = page.locator("fieldset[data-item='imitating_robot']")
    expect(question.locator("label.choice")).to_have_text([*robots, "I don't know"])
    page.get_by_role("radio", name="Yes").check()
    question.get_by_role("radio", name=robots[1]).check()
    page.get_by_role("button", name=SAVE).click()  # the open questions are optional
    expect(page.get_by_role("heading", name="What this study was about")).to_be_visible()
    expect(page.get_by_text("imitated your own head movements", exact=False)).to_be_visible()
    fits(page)
    page.reload()  # the link has stopped working, but the debriefing is still there
    expect(page.get_by_role("heading", name="What this study was about")).to_be_visible()
    final = {r.item: r for r in rows(engine, QuestionnaireResponse, position=0)}
    assert (final["imitating_robot"].value, final["noticed_imitation"].text) == (2, "yes")
    assert final["comments"].skipped
    context.close()
    http.close()


@pytest.mark.parametrize("size", SIZES, ids=lambda s: f"{s[0]}x{s[1]}")
def test_declining_ends_the_session_politely_and_keeps_nothing_else(
    browser: Browser, server: LiveServer, engine: Engine, size: tuple[int, int]
) -> None:
    pi, study_id, http = staff(server, engine)
    wizard = WizardBot.create(pi, study_id)
    context = small_phone(browser, size)
    page = context.new_page()
    page.set_default_timeout(ACTION_TIMEOUT_MS)
    page.goto(server.url + wizard.phone_path)
    page.get_by_role("button", name="I do not want to take part").click()
    expect(page.get_by_text("You have chosen not to take part")).to_be_visible()
    fits(page)
    page.reload()
    expect(page.get_by_text("You have chosen not to take part")).to_be_visible()
    session = rows(engine, SessionRow, id=wizard.session_id)[0]
    assert (session.state, session.end_reason, session.consent_at) == (
        "ended", "consent_declined", None
    )  # fmt: skip
    assert rows(engine, Participant, id=session.participant_id)[0].status == "declined"
    assert rows(engine, QuestionnaireResponse) == []
    kinds = {e.kind for e in rows(engine, Event, session_id=session.id, source="participant")}
    assert kinds <= {"consent.declined", "phone.connected", "phone.disconnected"}
    assert "consent.declined" in kinds
    assert wizard.refresh()["allowed"] == [{"action": "none", "why": "ended"}]
    context.close()
    http.close()
