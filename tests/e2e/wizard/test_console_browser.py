"""The wizard console in a real Chromium against a real server: a whole interaction driven
from the keyboard and the mouse, with the participant's answers arriving live.

No worker runs in these tests, so every prompt is logged as "not sent: worker unreachable";
the worker path (ack and speech latencies) needs the lead's bridge wiring.
"""

from __future__ import annotations

import re

import pytest
from playwright.sync_api import Page, expect
from sqlalchemy import Engine, select

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import StaffUser
from tests.e2e.wizard.conftest import Console, log_in
from tests.support.bots import StaffApi, study_with_plan
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


def played(console: Console) -> list[dict[str, object]]:
    return [e for e in console.events() if e["kind"] == "prompt.played"]


def expect_played(console: Console, count: int) -> dict[str, object]:
    """Wait until the timeline shows ``count`` plays; return the last one."""
    expect(console.page.locator("#timeline li[data-kind='prompt.played']")).to_have_count(count)
    plays = played(console)
    assert len(plays) == count
    return plays[-1]


def start_discussion(page: Page) -> None:
    primary = page.locator("#primary-action")
    expect(primary).to_contain_text("Start the session")
    primary.click()
    expect(primary).to_contain_text("Start interaction 1")
    page.keyboard.press("Control+Enter")
    expect(page.locator("#bar-step")).to_have_text("discussion")
    # The server's booth flow sets the robot up (test_console_booth_flow_browser.py); this
    # server has no worker link, and the console sends nothing of its own.


def test_prompts_play_by_click_shortcut_and_search(console: Console) -> None:
    page = console.page
    interaction = console.wizard.interaction(1)
    start_discussion(page)
    page.get_by_role("button", name=re.compile(r"Introduce")).click()
    first = expect_played(console, 1)
    assert first["payload"]["group"].startswith("intro_")  # type: ignore[index]
    expect(page.locator("#now-playing")).to_have_attribute("data-phase", "not-sent")
    expect(page.locator("#now-label")).to_contain_text("worker unreachable")
    expect(page.locator("#timeline")).to_contain_text("Not sent")

    page.keyboard.press("1")
    describe = expect_played(console, 2)
    assert describe["payload"]["item"] == interaction["presented_order"][0]  # type: ignore[index]
    page.keyboard.press("Shift+2")
    ask = expect_played(console, 3)
    assert ask["payload"]["stage"] == "item_question"  # type: ignore[index]
    assert ask["payload"]["item"] == interaction["presented_order"][1]  # type: ignore[index]
    page.keyboard.press("y")
    assert expect_played(console, 4)["payload"]["group"] == "ack_yes"  # type: ignore[index]
    # Never sent (no worker): the participant heard nothing, so no tick but "not voiced".
    yes = page.locator("button.pb[data-group='ack_yes']")
    expect(yes).to_have_class(re.compile("not-voiced"))
    expect(yes.locator(".pb-played")).to_have_text("✗ not voiced")
    expect(yes.locator(".pb-played")).to_have_attribute(
        "title", "Not voiced: worker unreachable"
    )
    expect(yes).not_to_have_class(re.compile(r"\bplayed\b"))

    page.keyboard.press("/")
    expect(page.locator("#prompt-search")).to_be_focused()
    page.keyboard.type("good point")
    expect(page.locator("#search-count")).to_have_text("1 match")
    page.keyboard.press("Enter")
    assert expect_played(console, 5)["payload"]["group"] == "ack_good_point"  # type: ignore[index]
    page.keyboard.press("Escape")
    expect(page.locator("#prompt-search")).to_have_value("")

    page.keyboard.press("Space")
    expect(page.locator("#timeline li[data-kind='prompt.stopped']")).to_have_count(1)
    assert len(played(console)) == 5, "Space stops; it must not also press a focused button"


def test_a_full_interaction_with_the_participant(console: Console, phone_page: Page) -> None:
    page, phone = console.page, phone_page
    expect(phone.locator("#connection")).to_have_text("Connected")
    expect(page.locator("#phone-state")).to_have_text("phone connected")
    start_discussion(page)
    robot = console.wizard.interaction(1)["robot_name"]
    expect(phone.get_by_role("heading", name=f"Listen to {robot}")).to_be_visible()
    page.keyboard.press("Control+Enter")
    expect(page.locator("#bar-step")).to_have_text("ranking")
    expect(page.locator("#primary-action")).to_contain_text("Waiting for the participant's ranking")

    ranking = rank_on_the_phone(console, phone)
    names = {item["id"]: item["name"] for item in console.wizard.interaction(1)["items"]}
    expect(page.locator("#live-ranking li")).to_have_count(5)
    expect(page.locator("#live-ranking li").first).to_have_text(names[ranking[0]])
    expect(page.locator("#timeline")).to_contain_text("Phone: ranking submitted")

    page.keyboard.press("Control+Enter")
    panel = page.locator("#negotiation-body")
    expect(panel).to_contain_text("Suggestion 1 of 3")
    expect(page.locator("#suggestion-prompts button.pb").first).to_be_visible()
    page.keyboard.press("m")
    assert expect_played(console, 1)["payload"]["stage"] == "suggestion"  # type: ignore[index]

    page.keyboard.press("a")
    expect(panel).to_contain_text("Suggestion 2 of 3")
    phone_shows_the_current_ranking(console, phone)
    expect(phone.locator("#current-ranking li.moved").first).to_be_visible()
    expect(page.locator("#live-ranking li.moved").first).to_be_visible()

    page.keyboard.press("d")
    expect(panel).to_contain_text("Suggestion 3 of 3")
    expect(page.locator("#undo-button")).to_be_visible()
    page.keyboard.press("u")
    expect(panel).to_contain_text("Suggestion 2 of 3")
    expect(page.locator("#timeline")).to_contain_text("decision undone")
    page.keyboard.press("d")
    expect(panel).to_contain_text("Suggestion 3 of 3")
    page.keyboard.press("a")
    expect(page.locator("#negotiation-body li.yes")).to_have_count(2)
    expect(page.locator("#negotiation-body li.no")).to_have_count(1)
    decisions = [s["accepted"] for s in console.wizard.refresh()["interactions"][0]["suggestions"]]
    assert decisions == [True, False, True]
    phone_shows_the_current_ranking(console, phone)

    switch_to_an_unplanned_condition(console)

    page.keyboard.press("Control+Enter")
    expect(page.locator("#bar-step")).to_have_text("questionnaire")
    expect(phone.get_by_role("heading", name=f"Questions about {robot}")).to_be_visible()
    answer_page(phone, 1)
    expect(page.locator("#participant-view")).to_contain_text("1 of 4 done")
    for part in (2, 3, 4):
        answer_page(phone, part)
    expect(page.locator("#primary-action")).to_contain_text("Start interaction 2")
    # the four pages after interaction 1, and the questions before the session
    expect(page.locator("#timeline li[data-kind='questionnaire.submitted']")).to_have_count(5)

    timeline_holds_every_event(console)
    page.reload()
    timeline_holds_every_event(console)
    expect(page.locator("#bar-position")).to_have_text("2 of 3")


def rank_on_the_phone(console: Console, phone: Page) -> list[str]:
    """The participant moves the last item up once and submits; returns the ranking."""
    expect(phone.get_by_role("heading", name="Rank the items")).to_be_visible()
    rows = phone.locator("#ranking-list li")
    before = rows.evaluate_all("els => els.map(e => e.dataset.id)")
    last = console.wizard.interaction(1)["items"][-1]["name"]
    phone.get_by_role("button", name=f"Move {last} up").click()
    phone.get_by_role("button", name="Submit my ranking").click()
    expect(phone.locator("#save-status")).to_have_text("Ranking saved ✓")
    ranking = [*before[:-2], before[-1], before[-2]]
    assert console.wizard.refresh()["interactions"][0]["initial_ranking"] == ranking
    return ranking


def phone_shows_the_current_ranking(console: Console, phone: Page) -> None:
    current = console.wizard.refresh()["interactions"][0]["current_ranking"]
    rows = phone.locator("#current-ranking li")
    for index, item in enumerate(current):
        expect(rows.nth(index)).to_have_attribute("data-id", item)


def answer_page(phone: Page, part: int) -> None:
    expect(phone.locator(".progress-label")).to_have_text(f"Part {part} of 4")
    for field in phone.locator("fieldset.question").all():
        if field.locator("textarea").count():
            field.locator("textarea").fill("It was fine.")
        else:
            field.locator("label.point").nth(3).click()
    phone.get_by_role("button", name=re.compile(r"^Save")).click()
    expect(phone.locator("#save-status")).to_have_text("Answers saved ✓")


def switch_to_an_unplanned_condition(console: Console) -> None:
    page = console.page
    planned = console.wizard.interaction(1)["planned_condition"]
    other = next(c for c in console.wizard.snapshot["conditions"] if c != planned)
    page.locator(f"#condition-switch button[data-condition='{other}']").click()
    dialog = page.locator("#confirm-dialog")
    expect(dialog).to_be_visible()
    expect(dialog).to_contain_text(f'planned as "{planned}"')
    page.get_by_role("button", name="Switch and log deviation").click()
    expect(page.locator("#condition-note")).to_contain_text(f"Deviation: running {other}")
    expect(page.locator("#timeline li[data-kind='plan.deviation']")).to_have_count(1)
    assert console.wizard.refresh()["interactions"][0]["condition"] == other


def timeline_holds_every_event(console: Console) -> None:
    events = console.events()
    rows = console.page.locator("#timeline li")
    expect(rows).to_have_count(len(events))
    shown = {int(i) for i in rows.evaluate_all("rows => rows.map(r => r.dataset.id)")}
    assert shown == {int(e["id"]) for e in events}  # type: ignore[call-overload]


def test_cancelling_a_condition_switch_changes_nothing(console: Console) -> None:
    page = console.page
    expect(page.locator("#condition-switch button")).to_have_count(3)
    planned = console.wizard.interaction(1)["planned_condition"]
    other = next(c for c in console.wizard.snapshot["conditions"] if c != planned)
    page.locator(f"#condition-switch button[data-condition='{other}']").click()
    page.get_by_role("button", name="Cancel").click()
    expect(page.locator("#confirm-dialog")).to_be_hidden()
    assert console.wizard.refresh()["interactions"][0]["condition"] == planned
    assert not [e for e in console.events() if e["kind"] == "condition.switched"]


def test_the_console_links_the_booth_check_of_its_booth_for_this_session(
    console: Console,
) -> None:
    page = console.page
    session_id = console.wizard.session_id
    link = page.locator("#booth-check-link")
    expect(link).to_have_attribute("href", f"/booths/booth-1/check?session_id={session_id}")
    link.click()
    expect(page.get_by_role("heading", name="Booth check: booth-1")).to_be_visible()
    expect(page.locator("#booth-check")).to_have_attribute("data-session", str(session_id))
    page.get_by_role("button", name="Run the check").click()  # no worker: NOT READY, stored
    expect(page.locator("#check-summary")).to_contain_text("NOT READY")
    checked = [e for e in console.events() if e["kind"] == "booth.checked"]
    assert [e["session_id"] for e in checked] == [session_id]


def test_the_console_says_when_the_worker_and_the_server_are_unreachable(
    console: Console,
) -> None:
    page = console.page
    alarm = page.locator("#health .alarm")
    expect(alarm).to_contain_text("Worker unreachable")
    expect(alarm).to_contain_text("Prompts are logged but not sent")
    expect(page.locator("#health .chip[data-check='worker']")).to_have_attribute(
        "data-state", "bad"
    )
    console.server.stop()
    expect(page.locator("#conn-banner")).to_be_visible(timeout=15_000)
    page.keyboard.press("y")
    expect(page.locator("#conn-banner")).to_contain_text("server is unreachable")


def test_the_wizard_opens_the_next_participant_s_session_from_the_picker(
    live_server: LiveServer, staff: StaffApi, page: Page, engine: Engine
) -> None:
    study_with_plan(staff, participants=2)
    log_in(page, live_server.url, engine, "/wizard")
    page.get_by_label("Booth").fill("booth-2")
    page.get_by_role("button", name="Register and open session").click()
    expect(page.locator("#bar-participant")).to_have_text("P001")
    # The session waits for the participant's consent on the phone before it can start.
    expect(page.locator("#primary-action")).to_contain_text("Waiting for the participant's consent")
    expect(page.locator("#phone-qr")).to_be_visible()
    expect(page.locator("#health")).to_contain_text("Robot booth-2")


def test_a_console_whose_login_is_ended_goes_to_the_login_page(
    console: Console, staff: StaffApi, engine: Engine
) -> None:
    """The PI deactivates the wizard while the console is open: its socket is closed
    (4401) and the page asks for a login instead of reconnecting for ever."""
    page = console.page
    expect(page.locator("#timeline")).to_be_visible()
    with session_scope(build_sessionmaker(engine)) as db:
        wiz_id = db.scalars(select(StaffUser.id).where(StaffUser.username == "wiz")).one()
    done = staff.http.post(f"/pi/staff/{wiz_id}/deactivate", headers={"X-CSRF-Token": staff.csrf})
    assert done.status_code == 303
    page.wait_for_url(re.compile(r"/login\?next=%2Fwizard%2Fsessions%2F\d+$"))
    expect(page.get_by_label("Username")).to_be_visible()
