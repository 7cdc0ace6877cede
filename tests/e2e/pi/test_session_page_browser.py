"""The PI's pages as a PI reads them (issue 28): a whole session's page in words (item names,
questionnaire titles and questions, choices by their labels, the manipulation check's robot,
skipped answers said so; no ids, no "None", no "interaction -1"), and a way back to the PI
menu from the staff accounts, the studies and the booth check."""

from __future__ import annotations

import random
import re

import httpx
import pytest
from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from chameleons.experiment.study import load_default_study
from tests.backend.test_auth import add_user
from tests.support.bots import ParticipantBot, WizardBot, answers_for, staff_api, study_with_plan
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser
PASSWORD = "correct horse battery"


def log_in(page: Page, server: LiveServer, engine: Engine, path: str) -> None:
    add_user(engine, "pia", PASSWORD, "pi")
    page.goto(f"{server.url}/login?next={path}")
    page.get_by_label("Username").fill("pia")
    page.get_by_label("Password").fill(PASSWORD)
    page.get_by_role("button", name="Log in").click()
    page.wait_for_url(f"**{path}")


def run_a_session(server: LiveServer, engine: Engine) -> tuple[int, dict[str, object]]:
    """A whole session through the API; the questions about the participant answered but
    for the optional gender question, and the final ones with the robot of interaction 2."""
    rng = random.Random(11)
    with httpx.Client(base_url=server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2))
        phone = ParticipantBot(http, wizard.token)
        state = phone.consent(True)["state"]
        while state["view"] == "questionnaire" and state.get("before"):
            page = state["questionnaire"]
            answers = answers_for(page, rng)
            answers.pop("gender", None)  # optional: skipped
            state = phone.submit_questionnaire(-1, page["id"], answers)["state"]
        wizard.start()
        for position in (1, 2, 3):
            wizard.advance(position, "discussion")
            wizard.advance(position, "ranking")
            phone.rank(rng)
            wizard.advance(position, "negotiation")
            wizard.negotiate(position, lambda _s: True)
            wizard.advance(position, "questionnaire")
            phone.answer_questionnaires(position, rng)
        state = phone.state()
        while state["view"] == "questionnaire":
            page = state["questionnaire"]
            answers = answers_for(page, rng)
            for item in page["items"]:
                if item["type"] == "robot":
                    answers[item["id"]] = 2
                elif item["type"] == "choice":
                    answers[item["id"]] = item["options"][0]["id"]
            state = phone.submit_questionnaire(0, page["id"], answers)["state"]
        snapshot = wizard.refresh()
    assert snapshot["state"] == "complete"
    return wizard.session_id, snapshot


def test_the_session_page_reads_in_words(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    session_id, snapshot = run_a_session(live_server, engine)
    log_in(page, live_server, engine, f"/pi/sessions/{session_id}")
    study = load_default_study()
    main = page.locator("main")
    expect(main.get_by_role("heading", name="Timeline")).to_be_visible()
    text = main.inner_text()
    assert not re.search(r"\bNone\b", text), repr(text[max(0, text.find("None") - 200) :][:300])
    assert "interaction -1" not in text

    # Suggestions by the item's name, as the rankings beside them.
    first = snapshot["interactions"][0]  # type: ignore[index]
    names = {item["id"]: item["name"] for item in first["items"]}
    rows = page.locator("#interaction-1 table.suggestions tbody tr")
    expect(rows).to_have_count(3)
    for index, suggestion in enumerate(first["suggestions"]):
        cell = rows.nth(index).locator("td").nth(1)
        expect(cell).to_have_text(names[suggestion["item"]])

    # Questionnaires by title, questions by their text, a scored page with its score.
    credibility = study.questionnaire("credibility")
    block = page.locator("#interaction-1 [data-questionnaire='credibility']")
    expect(block.locator("h4")).to_have_text(re.compile(rf"^{credibility.title}: score \d"))
    first_item = credibility.items[0]
    question = first_item.text or f"{first_item.left} \u2013 {first_item.right}"
    expect(block.locator("tbody tr").first.locator("td").first).to_have_text(question)

    # About the participant: choices by their labels, the skipped one said so.
    before = page.locator("#before-answers")
    about = study.questionnaire("demographics")
    gender = next(item for item in about.items if item.id == "gender")
    skipped = before.locator("tr", has_text=gender.text)
    expect(skipped.locator("td").nth(1)).to_have_text("skipped")
    age = next(item for item in about.items if item.type == "choice" and item.id != "gender")
    labels = [option.label for option in age.options]
    answered = before.locator("tr", has_text=age.text).locator("td").nth(1)
    assert answered.inner_text() in labels

    # The manipulation check's robot by the interaction and the name it was met under.
    robot = snapshot["interactions"][1]["robot_name"]  # type: ignore[index]
    expect(page.locator("#final-answers")).to_contain_text(
        f"the robot of interaction 2 ({robot})"
    )
    timeline = page.locator("#timeline li[data-kind='questionnaire.submitted']").first
    expect(timeline).to_contain_text("answered (before the interactions)")


@pytest.mark.parametrize("path", ["/pi/staff", "/studies", "/booths/booth-1/check"])
def test_a_way_back_to_the_pi_menu(
    live_server: LiveServer, page: Page, engine: Engine, path: str
) -> None:
    log_in(page, live_server, engine, path)
    page.get_by_role("link", name="← PI dashboard").click()
    page.wait_for_url(f"{live_server.url}/pi")
    expect(page.get_by_role("navigation", name="PI dashboard")).to_be_visible()


def test_the_booth_check_of_a_session_leads_back_to_its_console(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2))
    path = f"/booths/booth-1/check?session_id={wizard.session_id}"
    log_in(page, live_server, engine, path.split("?")[0])
    page.goto(live_server.url + path)
    page.get_by_role("link", name="← Wizard console").click()
    page.wait_for_url(f"{live_server.url}/wizard/sessions/{wizard.session_id}")
