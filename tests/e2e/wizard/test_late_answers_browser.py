"""In Chromium: an HTTP answer that arrives after the live socket has already shown newer
changes (a busy laptop reorders them) is not allowed to take those changes off the page:
neither the console's page-load read nor the reply to a phone's submission.

Each test reads the answer at the server at once (``route.fetch``) and hands it to the page
only after newer changes have reached it, which is the order a loaded machine can produce.
"""

from __future__ import annotations

from typing import Any

import pytest
from playwright.sync_api import Page, Route, expect

from tests.e2e.wizard.conftest import Console
from tests.support.browser import wait_until_routed

pytestmark = pytest.mark.browser


class Held:
    """Answers read at the server when the page asked, handed to the page later."""

    def __init__(self) -> None:
        self.answers: list[tuple[Route, Any]] = []

    def __call__(self, route: Route) -> None:
        self.answers.append((route, route.fetch()))

    def wait(self, page: Page) -> None:
        wait_until_routed(page, self.answers)

    def hand_over(self, page: Page) -> None:
        route, answer = self.answers.pop(0)
        with page.expect_request_finished(lambda request: request.url == route.request.url):
            route.fulfill(response=answer)


def test_a_late_answer_to_the_page_loads_read_does_not_undo_live_changes(
    console: Console,
) -> None:
    """The page reads the console over HTTP when it loads while its WebSocket sends the same
    and then every change. On a busy laptop the HTTP answer can come last: read before the
    changes, it must not take them off the page."""
    page, wizard = console.page, console.wizard
    held = Held()
    page.route(f"**/api/wizard/sessions/{wizard.session_id}/console", held)
    page.reload()
    expect(page.locator("#timeline li[data-kind='session.created']")).to_be_visible()
    held.wait(page)
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.staff.post(f"/api/sessions/{wizard.session_id}/notes", {"text": "kept"})
    note = page.locator("#timeline li[data-kind='wizard.note']")
    expect(note).to_be_visible()
    held.hand_over(page)
    page.unroute(f"**/api/wizard/sessions/{wizard.session_id}/console")
    wizard.staff.post(f"/api/sessions/{wizard.session_id}/notes", {"text": "after"})
    expect(note).to_have_count(2)  # the second note's row marks the stale answer as handled
    expect(page.locator("#timeline li[data-kind='session.started']")).to_have_count(1)
    expect(page.locator("#bar-step")).to_have_text("discussion")  # the bar is not undone either


def test_a_late_reply_to_a_phones_ranking_does_not_take_the_participant_back(
    console: Console, phone_page: Page
) -> None:
    """The reply to the ranking (the phone's next view as the submission left it) comes
    after the socket has shown the questionnaire the wizard opened meanwhile."""
    page, wizard = phone_page, console.wizard
    robot = wizard.interaction(1)["robot_name"]
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    expect(page.get_by_role("heading", name="Rank the items")).to_be_visible()
    held = Held()
    page.route("**/api/phone/*/ranking", held)
    page.get_by_role("button", name="Submit my ranking").click()
    held.wait(page)
    assert wizard.refresh()["interactions"][0]["initial_ranking"]  # stored; the reply is held
    wizard.advance(1, "negotiation")
    for index in (1, 2, 3):
        wizard.decide(1, index, index != 2)
    wizard.advance(1, "questionnaire")
    questions = page.get_by_role("heading", name=f"Questions about {robot}")
    expect(questions).to_be_visible()
    held.hand_over(page)
    expect(page.locator("#save-status")).to_have_text("Ranking saved ✓")  # the reply was read
    expect(questions).to_be_visible()
    expect(page.locator("#app")).to_have_attribute("data-view", "questionnaire")
