"""In Chromium: a technician opens the booth check, runs it, and reads each step; without a
worker on the booth it is NOT READY with the reasons, and the run is stored with the
session (``booth.checked`` on its timeline)."""

from __future__ import annotations

import httpx
import pytest
from playwright.sync_api import Page, Route, expect
from sqlalchemy import Engine

from tests.backend.test_auth import add_user
from tests.support.bots import WizardBot, staff_api, study_with_plan
from tests.support.browser import wait_until_routed
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


def test_the_booth_check_page_runs_the_check_and_stores_it(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2), booth="booth-7")
        add_user(engine, "tech", "correct horse battery", "wizard")
        target = f"/booths/booth-7/check?session_id={wizard.session_id}"
        page.goto(f"{live_server.url}/login?next={target}")
        page.get_by_label("Username").fill("tech")
        page.get_by_label("Password").fill("correct horse battery")
        page.get_by_role("button", name="Log in").click()
        expect(page.get_by_role("heading", name="Booth check: booth-7")).to_be_visible()
        expect(page.locator("#booth-check")).to_contain_text("turn your head to the left")

        page.get_by_role("button", name="Run the check").click()
        expect(page.locator("#check-summary")).to_contain_text("NOT READY")
        rows = page.locator("#check-steps tbody tr")
        expect(rows).to_have_count(6)
        face = page.locator("tr[data-step='face']")
        expect(face).to_have_attribute("data-status", "fail")
        expect(face).to_contain_text("no worker for this booth")
        head = page.locator("tr[data-step='head']")
        expect(head).to_contain_text("Turn your head left, then nod")
        expect(page.locator("tr[data-step='disk']")).to_contain_text("GB free")

        events = pi.get(f"/api/sessions/{wizard.session_id}/events")
        stored = [e for e in events if e["kind"] == "booth.checked"]
        assert len(stored) == 1
        assert stored[0]["payload"]["passed"] is False
        assert [s["id"] for s in stored[0]["payload"]["steps"]] == [
            "face", "head", "robot", "copy", "speech", "disk",
        ]  # fmt: skip


def test_the_booth_check_command_runs_the_same_check(
    live_server: LiveServer, engine: Engine
) -> None:
    from click.testing import CliRunner

    from chameleons.cli.booth_check_command import booth_check

    add_user(engine, "tech", "correct horse battery", "wizard")
    result = CliRunner().invoke(
        booth_check, ["booth-9", "--server", live_server.url, "--user", "tech", "--no-wait"],
        input="correct horse battery\n",
    )  # fmt: skip
    assert result.exit_code == 1, result.output
    assert "FAIL  Face stream: no worker for this booth" in result.output
    assert "GB free" in result.output
    assert "NOT READY" in result.output
    wrong = CliRunner().invoke(
        booth_check, ["booth-9", "--server", live_server.url, "--user", "tech", "--no-wait",
                      "--password", "wrong"],
    )  # fmt: skip
    assert wrong.exit_code == 1
    assert "the check could not run" in wrong.output


def test_the_page_refuses_the_check_while_an_interaction_runs_on_the_booth(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2), booth="booth-8")
        wizard.start()
        wizard.advance(1, "discussion")
        add_user(engine, "tech", "correct horse battery", "wizard")
        page.goto(f"{live_server.url}/login?next=/booths/booth-8/check")
        page.get_by_label("Username").fill("tech")
        page.get_by_label("Password").fill("correct horse battery")
        page.get_by_role("button", name="Log in").click()
        page.get_by_role("button", name="Run the check").click()
        summary = page.locator("#check-summary")
        expect(summary).to_contain_text("The check could not run: Interaction 1 of session")
        expect(summary).to_contain_text("would take the robot from the participant")
        expect(page.locator("#check-prompt")).to_be_hidden()
        expect(page.get_by_role("button", name="Run the check")).to_be_enabled()
        events = pi.get(f"/api/sessions/{wizard.session_id}/events")
        assert not [e for e in events if e["kind"] == "booth.checked"]


def test_the_run_button_waits_for_the_pages_script(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    """A click before the script listens would do nothing on a slow laptop: the button comes
    disabled and the script enables it."""
    add_user(engine, "tech", "correct horse battery", "wizard")
    held: list[Route] = []
    page.route("**/booth/check.js", lambda route: held.append(route))
    page.goto(f"{live_server.url}/login?next=/booths/booth-6/check")
    page.get_by_label("Username").fill("tech")
    page.get_by_label("Password").fill("correct horse battery")
    page.get_by_role("button", name="Log in").click()
    expect(page.get_by_role("heading", name="Booth check: booth-6")).to_be_visible()
    button = page.get_by_role("button", name="Run the check")
    expect(button).to_be_disabled()
    wait_until_routed(page, held)
    expect(button).to_be_disabled()  # the script is held: the button still waits
    held[0].continue_()
    expect(button).to_be_enabled()
