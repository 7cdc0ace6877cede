"""The booth check page lets the technician pick which of the study's copy conditions to
check (issue 31): the chosen condition's words are shown, and the check the page runs asks
the server for that condition."""

from __future__ import annotations

import httpx
import pytest
from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from tests.backend.test_auth import add_user
from tests.experiment.study_files import default_document, study_yaml
from tests.support.bots import WizardBot, staff_api, study_with_plan
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser
BOOTH = "booth-1"


def two_copies() -> str:
    document = default_document()
    document["conditions"] = {
        "head_only": {"label": "Head only", "behaviour": "copy",
                      "params": {"channels": "head", "delay": 1.0}},
        "jitter": {"label": "Jittered", "behaviour": "copy",
                   "params": {"delay": {"uniform": [0.5, 1.5]}}},
        "still": {"label": "Still", "behaviour": "still"},
    }  # fmt: skip
    return study_yaml(document)


def test_the_technician_picks_the_condition_and_the_check_runs_it(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        WizardBot.create(pi, study_with_plan(pi, participants=6, yaml=two_copies()), booth=BOOTH)
    add_user(engine, "tech", "correct horse battery", "wizard")
    page.goto(f"{live_server.url}/login?next=/booths/{BOOTH}/check")
    page.get_by_label("Username").fill("tech")
    page.get_by_label("Password").fill("correct horse battery")
    page.get_by_role("button", name="Log in").click()
    picker = page.get_by_label("Condition to check")
    expect(picker).to_have_value("head_only")  # the study's first copy condition
    expect(page.locator("#check-words")).to_have_text("copies head, 1 s late, mirror image")
    picker.select_option("jitter")
    page.get_by_role("button", name="Choose").click()
    expect(page.locator("#check-condition")).to_have_text("jitter")
    expect(page.locator("#check-words")).to_have_text(
        "copies everything, 0.5-1.5 s late (uniform, redrawn every 10 s), mirror image, seed 0"
    )
    run = page.get_by_role("button", name="Run the check")
    expect(run).to_be_enabled()
    with page.expect_request(lambda r: r.method == "POST" and "/check" in r.url) as sent:
        run.click()
    assert "condition=jitter" in sent.value.url
    expect(page.locator("#check-summary")).not_to_have_text("Checking: follow the prompts.")
