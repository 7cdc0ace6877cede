"""The example study (four conditions) on the PI's studies page and in the wizard console:
the study is created by pasting its file, and the console has a button per condition with
what the robot runs."""

from __future__ import annotations

import random
import re

from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from tests.e2e.wizard.conftest import log_in
from tests.experiment.test_example_study import CONDITIONS, EXAMPLE
from tests.support.bots import ParticipantBot, StaffApi, WizardBot
from tests.support.live_server import LiveServer


def test_the_example_study_loads_on_the_studies_page(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    from tests.backend.test_auth import add_user

    add_user(engine, "pia", "correct horse", "pi")
    page.goto(f"{live_server.url}/login?next=/studies")
    page.get_by_label("Username").fill("pia")
    page.get_by_label("Password").fill("correct horse")
    page.get_by_role("button", name=re.compile("Log in", re.I)).click()
    page.wait_for_url("**/studies")
    page.get_by_label(re.compile("^Study YAML")).fill(EXAMPLE.read_text(encoding="utf-8"))
    page.get_by_role("button", name="Create study").click()
    expect(page.locator("#studies")).to_contain_text("Copy delay")
    page.get_by_label("Participants").fill("8")
    page.get_by_role("button", name="Generate plan").click()
    expect(page.locator("#studies tbody tr").first).to_contain_text("8")


def test_the_console_has_a_button_per_condition_of_the_example_study(
    live_server: LiveServer, staff: StaffApi, page: Page, engine: Engine
) -> None:
    body = {"plan_seed": 7, "yaml": EXAMPLE.read_text(encoding="utf-8")}
    study = staff.post("/api/studies", body)
    staff.post(f"/api/studies/{study['id']}/plan", {"participants": 8})
    wizard = WizardBot.create(staff, int(study["id"]))
    ParticipantBot(staff.http, wizard.token).prepare(random.Random(1))
    path = f"/wizard/sessions/{wizard.session_id}"
    log_in(page, live_server.url, engine, path)
    page.wait_for_url(f"**{path}")
    page.locator("#primary-action").click()  # start the session
    expect(page.locator("#primary-action")).to_contain_text("Start interaction 1")
    buttons = page.locator("#condition-switch button")
    expect(buttons).to_have_count(4)
    shown = buttons.evaluate_all("bs => bs.map(b => b.dataset.condition)")
    assert shown == CONDITIONS
    planned = wizard.refresh()["interactions"][0]["condition"]
    expect(page.locator(f"#condition-switch button[data-condition='{planned}']")).to_have_attribute(
        "aria-pressed", "true"
    )
    delay = {"copy_fast": "1", "copy_slow": "4"}.get(planned)
    if delay is not None:  # the console says what the robot runs, with its parameter
        expect(page.locator("#condition-behaviour")).to_contain_text(delay)
