"""Every kind of page runs under the Content-Security-Policy in Chromium without a single
violation, console error or uncaught exception: login, home, PI pages (dashboard, a
session, analysis with its plots and extended part, monitor, export, staff, power, studies),
the wizard's session list and console, the booth check (run once), the robot display
(connected to its WebSocket) and the participant's phone (join and session pages).

Violations are caught three ways: Chromium's console error, an uncaught ``pageerror`` and
the DOM's ``securitypolicyviolation`` event, recorded by an init script in every page.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import httpx
import pytest
from playwright.sync_api import BrowserContext, ConsoleMessage, Page, expect
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker, session_scope
from tests.support.bots import PASSWORD, WizardBot, add_staff, staff_api
from tests.support.browser import wait_for_js
from tests.support.factories import PopulatedStudy, populate
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser

RECORD_VIOLATIONS = """
window.__cspViolations = [];
document.addEventListener("securitypolicyviolation", (e) => {
  window.__cspViolations.push(
    `${e.violatedDirective} blocked ${e.blockedURI} at ${e.sourceFile}:${e.lineNumber}`);
});
"""


@pytest.fixture
def study(engine: Engine, settings: Any) -> PopulatedStudy:
    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, 3, free_rows=2, recordings_dir=settings.data_dir / "recordings")
    add_staff(engine, "pia", "pi")
    return data


class Watcher:
    """Collects every problem a page reports; ``check`` reads the in-page record too."""

    def __init__(self) -> None:
        self.problems: list[str] = []

    def attach(self, page: Page) -> Page:
        page.add_init_script(RECORD_VIOLATIONS)
        page.on("console", self._console)
        page.on("pageerror", lambda error: self.problems.append(f"pageerror: {error}"))
        return page

    def _console(self, message: ConsoleMessage) -> None:
        if message.type in ("error", "warning") and "Content Security Policy" in message.text:
            self.problems.append(f"CSP: {message.text}")
        elif message.type == "error":
            self.problems.append(f"console error: {message.text} ({message.location})")

    def check(self, page: Page, what: str) -> None:
        violations = page.evaluate("window.__cspViolations")
        assert violations == [], f"{what}: {violations}"
        assert self.problems == [], f"{what}: {self.problems}"


@pytest.fixture
def watcher() -> Watcher:
    return Watcher()


@pytest.fixture
def phone_page(phone_context: BrowserContext, watcher: Watcher) -> Iterator[Page]:
    page = watcher.attach(phone_context.new_page())
    page.set_default_timeout(60_000)
    yield page
    page.close()


def _log_in(page: Page, base: str) -> None:
    page.goto(f"{base}/login?next=/pi")
    expect(page.get_by_role("heading", name="Staff login")).to_be_visible()
    page.get_by_label("Username").fill("pia")
    page.get_by_label("Password").fill(PASSWORD)
    page.get_by_role("button", name="Log in").click()
    expect(page.get_by_role("heading", name="Study progress")).to_be_visible()


def _visit(page: Page, watcher: Watcher, url: str, ready: Callable[[Page], None]) -> None:
    page.goto(url)
    ready(page)
    watcher.check(page, url)


def test_every_page_kind_runs_without_a_policy_violation(
    live_server: LiveServer,
    page: Page,
    phone_page: Page,
    watcher: Watcher,
    study: PopulatedStudy,
    engine: Engine,
) -> None:
    base = live_server.url
    with httpx.Client(base_url=base, timeout=30) as http:
        pi = staff_api(http, engine, "pi", name="pi-api")
        wizard = WizardBot.create(pi, study.study_id, booth="booth-1")
    watcher.attach(page)
    page.set_default_timeout(60_000)
    _log_in(page, base)
    watcher.check(page, "/login then /pi")

    def heading(name: str) -> Callable[[Page], None]:
        return lambda p: expect(p.get_by_role("heading", name=name).first).to_be_visible()

    def analysis_ready(p: Page) -> None:
        expect(p.locator("#extended")).to_have_attribute("data-loaded", "true", timeout=120_000)
        images = p.locator("#plots img")
        expect(images).to_have_count(4)
        for index in range(4):
            images.nth(index).scroll_into_view_if_needed()
            expect(images.nth(index)).to_have_js_property("complete", True, timeout=120_000)

    def monitor_ready(p: Page) -> None:
        # The page's script fetches the monitor every second: one answer proves it runs.
        with p.expect_response(lambda r: "/api/pi/monitor" in r.url and r.ok):
            pass

    def console_ready(p: Page) -> None:
        expect(p.locator("#console")).to_have_attribute("data-step", "pending")

    def timeline_ready(p: Page) -> None:
        expect(p.locator("#timeline li[data-category]").first).to_be_attached()

    def booth_check_ready(p: Page) -> None:
        expect(p.get_by_role("heading", name="Booth check: booth-1")).to_be_visible()
        p.get_by_role("button", name="Run the check").click()
        expect(p.locator("#check-summary")).to_contain_text("NOT READY")

    checks: list[tuple[str, Callable[[Page], None]]] = [
        ("/", lambda p: expect(p.locator("main")).to_be_visible()),
        (f"/pi/sessions/{study.session_ids[0]}", timeline_ready),
        ("/pi/analysis", analysis_ready),
        ("/pi/monitor", monitor_ready),
        ("/pi/export", heading("Export")),
        ("/pi/staff", lambda p: expect(p.locator("#staff-accounts")).to_be_visible()),
        ("/pi/power", lambda p: expect(p.locator("main")).to_be_visible()),
        ("/studies", lambda p: expect(p.locator("main")).to_be_visible()),
        ("/wizard", lambda p: expect(p.locator("main")).to_be_visible()),
        (f"/wizard/sessions/{wizard.session_id}", console_ready),
        (f"/booths/booth-1/check?session_id={wizard.session_id}", booth_check_ready),
    ]
    for path, ready in checks:
        _visit(page, watcher, base + path, ready)

    # The robot display: its script runs and its WebSocket opens (connect-src 'self').
    with page.expect_websocket(lambda ws: "/ws/display/booth-1" in ws.url) as socket_info:
        page.goto(f"{base}/display/booth-1")
    socket_info.value.wait_for_event("framereceived")
    expect(page.locator("canvas#face")).to_be_visible()
    watcher.check(page, "/display/booth-1")
    # With the 3D head: the import map (allowed by its hash) and three.js's modules.
    page.goto(f"{base}/display/booth-1?renderer=3d")
    wait_for_js(page, "window.robotDisplay && window.robotDisplay.renderer().ready", 90_000)
    assert page.evaluate("window.robotDisplay.renderer().kind") == "3d"
    expect(page.locator("canvas#face3d")).to_be_visible()
    watcher.check(page, "/display/booth-1?renderer=3d")

    # The participant's phone: the join page, then the session page with its live socket.
    _visit(phone_page, watcher, f"{base}/join", lambda p: expect(p.locator("form")).to_be_visible())
    phone_page.goto(base + wizard.phone_path)
    expect(phone_page.locator("#connection")).to_have_attribute("data-state", "online")
    expect(phone_page.locator("#app")).to_have_attribute("data-view", "consent")
    watcher.check(phone_page, wizard.phone_path)
