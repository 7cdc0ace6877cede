"""A participant walks through a whole three-interaction session on a 375 px phone while
a scripted wizard drives it through the API: a reload in the middle of a questionnaire,
an offline/online toggle while submitting, and a server restart on the way. Every answer
ends up stored exactly once."""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from playwright.sync_api import BrowserContext, Locator, Page, expect
from sqlalchemy import Engine, func, select

from chameleons.backend.app import create_app
from chameleons.backend.db import build_sessionmaker
from chameleons.backend.models import Event, QuestionnaireResponse
from chameleons.settings import Settings
from tests.support.bots import PASSWORD, StaffApi, WizardBot, add_staff, study_with_plan
from tests.support.browser import ACTION_TIMEOUT_MS
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser
SAVE = re.compile(r"^Save")


@pytest.fixture
def server(app: Any) -> Iterator[list[LiveServer]]:
    """The running server, in a list so the test can swap in a restarted one."""
    servers = [LiveServer(app).start()]
    yield servers
    servers[-1].stop()


def count(engine: Engine, model: Any, **where: Any) -> int:
    with build_sessionmaker(engine)() as db:
        return int(db.scalar(select(func.count()).select_from(model).filter_by(**where)) or 0)


def answer(page: Page, value: int = 4, text: str = "It was a fine conversation.") -> None:
    """Answer every question on the current page (scales: ``value``; open ones: ``text``)."""
    for field in page.locator("fieldset.question").all():
        if field.locator("textarea").count():
            field.locator("textarea").fill(text)
        elif field.locator("label.choice").count():  # a choice: its first answer
            field.locator("label.choice").first.click()
        else:
            field.locator("label.point").nth(value - 1).click()


def expect_part(page: Page, part: int, of: int = 4) -> None:
    expect(page.locator(".progress-label")).to_have_text(f"Part {part} of {of}")


def rank_and_submit(page: Page, wizard: WizardBot, position: int, drag: bool = False) -> None:
    """Move the last item up two places with the buttons, or drag it to the top."""
    expect(page.get_by_role("heading", name="Rank the items")).to_be_visible()
    rows = page.locator("#ranking-list li")
    before = rows.evaluate_all("els => els.map(e => e.dataset.id)")
    if drag:
        drag_to_top(page, rows.nth(len(before) - 1).locator(".handle"), rows.nth(0))
        expected = [before[-1], *before[:-1]]
    else:
        last = wizard.interaction(position)["items"][-1]["name"]
        page.get_by_role("button", name=f"Move {last} up").click()
        page.get_by_role("button", name=f"Move {last} up").click()
        expected = [*before[:-3], before[-1], *before[-3:-1]]
    assert rows.evaluate_all("els => els.map(e => e.dataset.id)") == expected
    page.get_by_role("button", name="Submit my ranking").click()
    expect(page.get_by_role("heading", name="Your ranking")).to_be_visible()
    expect(page.locator("#save-status")).to_have_text("Ranking saved ✓")
    assert wizard.refresh()["interactions"][position - 1]["initial_ranking"] == expected


def drag_to_top(page: Page, handle: Locator, first: Locator) -> None:
    """A pointer drag (SortableJS listens to pointer events) in small steps, away from the
    viewport's edges (where SortableJS would start scrolling the page). SortableJS swaps on
    pointer moves and animates each swap, so the pointer keeps nudging over the top item
    until the dragged item is there (polling, no fixed wait)."""
    page.evaluate(
        "scrollBy(0, document.getElementById('ranking-list').getBoundingClientRect().top - 80)"
    )
    dragged = handle.evaluate("h => h.parentElement.dataset.id")
    start = handle.bounding_box()
    top = first.bounding_box()
    assert start is not None
    assert top is not None
    x = start["x"] + start["width"] / 2
    page.mouse.move(x, start["y"] + start["height"] / 2)
    page.mouse.down()
    page.mouse.move(x, start["y"], steps=5)
    page.mouse.move(x, top["y"] + 6, steps=30)
    first_id = "() => document.querySelector('#ranking-list li').dataset.id"
    for nudge in range(200):
        if page.evaluate(first_id) == dragged:
            break
        page.mouse.move(x, top["y"] + 4 + nudge % 3)
    page.mouse.up()


def negotiate(page: Page, wizard: WizardBot, position: int) -> None:
    wizard.advance(position, "negotiation")
    wizard.decide(position, 1, True)
    ranking = wizard.interaction(position)["current_ranking"]
    rows = page.locator("#current-ranking li")
    expect(rows.first).to_be_visible()
    expect(page.locator("#current-ranking li.moved").first).to_be_visible()
    assert rows.evaluate_all("els => els.map(e => e.dataset.id)") == ranking
    wizard.decide(position, 2, False)
    wizard.decide(position, 3, True)
    expect(page.locator("#current-ranking li").first).to_have_attribute(
        "data-id", wizard.interaction(position)["current_ranking"][0]
    )
    wizard.advance(position, "questionnaire")


def test_a_participant_completes_a_whole_session_on_a_phone(
    phone_context: BrowserContext, server: list[LiveServer], engine: Engine, settings: Settings
) -> None:
    add_staff(engine, "wiz", "wizard")
    http = httpx.Client(
        base_url=server[0].url, timeout=60, limits=httpx.Limits(max_keepalive_connections=0)
    )
    staff = StaffApi(http).login("wiz", PASSWORD)
    pi_http = httpx.Client(base_url=server[0].url, timeout=60)
    add_staff(engine, "pia", "pi")
    study_id = study_with_plan(StaffApi(pi_http).login("pia", PASSWORD))
    pi_http.close()
    wizard = WizardBot.create(staff, study_id)
    page = phone_context.new_page()
    page.set_default_timeout(ACTION_TIMEOUT_MS)
    page.goto(server[0].url + wizard.phone_path)
    page.get_by_role("button", name="I agree to take part").click()
    expect(page.get_by_role("heading", name="About you")).to_be_visible()
    page.get_by_role("button", name=SAVE).click()  # every question about oneself is optional
    expect(page.get_by_role("heading", name="Welcome!")).to_be_visible()
    expect(page.locator("#connection")).to_have_text("Connected")
    wizard.start()
    expect(page.get_by_role("heading", name="Please wait")).to_be_visible()

    robot = wizard.interaction(1)["robot_name"]
    wizard.advance(1, "discussion")
    expect(page.get_by_role("heading", name=f"Listen to {robot}")).to_be_visible()
    wizard.advance(1, "ranking")
    expect(page.get_by_role("heading", name="Rank the items")).to_be_visible()
    check_small_screen_and_rotation(page)
    rank_and_submit(page, wizard, 1)
    negotiate(page, wizard, 1)

    expect(page.get_by_role("heading", name=f"Questions about {robot}")).to_be_visible()
    expect_part(page, 1)
    page.get_by_role("button", name=SAVE).click()  # nothing answered yet
    expect(page.get_by_role("alert")).to_have_text("Please answer question 1.")
    answer(page, 5)
    page.get_by_role("button", name=SAVE).click()
    expect_part(page, 2)

    # A reload in the middle of a questionnaire keeps what was typed.
    fields = page.locator("fieldset.question")
    fields.nth(0).locator("label.point").nth(1).click()
    fields.nth(1).locator("label.point").nth(6).click()
    page.reload()
    expect_part(page, 2)
    expect(fields.nth(0).locator("input").nth(1)).to_be_checked()
    expect(fields.nth(1).locator("input").nth(6)).to_be_checked()
    expect(page.locator(".answered")).to_have_text("2 of 10 answered")
    for index in range(2, fields.count()):
        fields.nth(index).locator("label.point").nth(2).click()
    page.get_by_role("button", name=SAVE).click()
    expect_part(page, 3)

    # Offline while submitting: kept on the phone, sent once the connection is back.
    answer(page, 6)
    phone_context.set_offline(True)
    page.get_by_role("button", name=SAVE).click()
    expect(page.locator("#save-status")).to_contain_text("Not sent yet")
    assert count(engine, QuestionnaireResponse, questionnaire="trust") == 0
    phone_context.set_offline(False)
    expect_part(page, 4)
    expect(page.locator("#save-status")).to_have_text("Answers saved ✓")

    # A server restart: the phone comes back to exactly where it was.
    page.locator("textarea").fill("The robot listened well.")
    server[0].stop()
    expect(page.locator("#connection")).to_have_text("Reconnecting…")
    server.append(LiveServer(create_app(settings), server[0].port).start())
    expect(page.locator("#connection")).to_have_text("Connected", timeout=15_000)
    expect_part(page, 4)
    expect(page.locator("textarea")).to_have_value("The robot listened well.")
    page.get_by_role("button", name=SAVE).click()
    expect(page.get_by_role("heading", name="Thank you!")).to_be_visible()

    for position in (2, 3):
        robot = wizard.interaction(position)["robot_name"]
        wizard.advance(position, "discussion")
        expect(page.get_by_role("heading", name=f"Listen to {robot}")).to_be_visible()
        wizard.advance(position, "ranking")
        rank_and_submit(page, wizard, position, drag=position == 2)
        negotiate(page, wizard, position)
        for part in (1, 2, 3, 4):
            expect_part(page, part)
            answer(page, position + part)
            page.get_by_role("button", name=SAVE).click()
        after = "Thank you!" if position < 3 else "Final questions"
        expect(page.get_by_role("heading", name=after)).to_be_visible()

    expect(page.get_by_role("heading", name="Final questions")).to_be_visible()
    expect_part(page, 1, of=1)
    answer(page, text="They moved differently.")
    page.get_by_role("button", name=SAVE).click()
    expect(page.get_by_role("heading", name="Thank you!")).to_be_visible()
    expect(page.get_by_text("This session has ended")).to_be_visible()
    page.reload()
    expect(page.get_by_text("This session has ended")).to_be_visible()

    assert wizard.refresh()["state"] == "complete"
    http.close()
    # 3 questions before (skipped), 3 interactions' questionnaires, 4 final questions
    assert count(engine, QuestionnaireResponse) == 3 + 3 * (12 + 10 + 6 + 1) + 4
    assert count(engine, QuestionnaireResponse, skipped=True) == 3
    assert count(engine, Event, kind="ranking.submitted") == 3
    assert count(engine, Event, kind="questionnaire.submitted") == 1 + 3 * 4 + 1


def check_small_screen_and_rotation(page: Page) -> None:
    """No sideways scrolling at 375 px or rotated; touch targets at least 44 px."""
    for width, height in ((375, 740), (740, 375)):
        page.set_viewport_size({"width": width, "height": height})
        overflow = page.evaluate("document.documentElement.scrollWidth - window.innerWidth")
        assert overflow <= 0
        box = page.locator("#ranking-list .move").first.bounding_box()
        assert box is not None
        assert box["height"] >= 44
        assert box["width"] >= 44
    page.set_viewport_size({"width": 375, "height": 740})
