"""In Chromium, where the user acts: the PI withdraws a participant whose face another
session's robot replayed (yoked natural), and the report and the other session's page say
what went; a registration the wizard never started is flagged on the dashboard and is
missing (not 0) in the analysis."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Page, expect
from sqlalchemy import Engine, select

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import Recording
from tests.backend.test_auth import add_user
from tests.backend.withdrawal.test_derived import yoke
from tests.e2e.pi.test_dashboard_browser import log_in
from tests.support.factories import populate
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


def test_withdrawing_a_face_another_session_replayed(
    live_server: LiveServer, page: Page, engine: Engine, settings: Any
) -> None:
    factory = build_sessionmaker(engine)
    with session_scope(factory) as db:
        data = populate(db, 4, recordings_dir=settings.data_dir / "recordings")
        replay = yoke(db, data, "P001", replayer=3)
        agent = db.scalars(
            select(Recording.path).where(
                Recording.interaction_id == replay.id, Recording.stream == "agent"
            )
        ).one()
        replay_session = data.session_ids[2]
    add_user(engine, "pia", "correct horse", "pi")
    assert Path(agent).exists()

    log_in(page, live_server, f"/pi/sessions/{replay_session}")
    # The timeline says whose face natural replayed.
    expect(page.locator("#timeline")).to_contain_text("replays participant P001")
    page.goto(live_server.url + "/pi")
    page.locator('tr[data-participant="P001"]').get_by_role("link", name="Withdraw…").click()
    page.get_by_label("Type the participant code").fill("P001")
    page.get_by_role("button", name="Delete all data of P001").click()
    removed = page.locator("#removed")
    expect(removed).to_contain_text("the robot's recording in P003's interaction 3")
    expect(removed).to_contain_text("replayed P001's face")
    expect(page.locator("#not-removed")).to_contain_text("Backups and copies of the database")
    assert not Path(agent).exists()

    page.goto(live_server.url + f"/pi/sessions/{replay_session}")
    expect(page.get_by_role("heading", name="Session of P003")).to_be_visible()
    expect(page.locator("body")).not_to_contain_text("P001")
    expect(page.locator("#timeline")).to_contain_text("participant withdrawn")
    expect(page.locator(".recordings a")).to_have_count(5)  # its own 3 + 2 robot recordings


def test_an_unstarted_registration_is_flagged_and_missing(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        populate(db, 6, free_rows=2)
    add_user(engine, "pia", "correct horse", "pi")
    log_in(page, live_server, "/wizard")
    page.get_by_role("button", name="Register and open session").click()
    expect(page.locator("#bar-participant")).to_have_text("P007")
    expect(page.locator("#primary-action")).to_be_disabled()  # not started (waits for consent)

    page.goto(live_server.url + "/pi")  # the session was never started
    row = page.locator('tr[data-participant="P007"]')
    expect(row.locator('[data-flag="not_started"]')).to_be_visible()
    page.goto(live_server.url + "/pi/analysis", wait_until="domcontentloaded")
    summary = page.locator("#analysis-summary")
    expect(summary).to_contain_text("7 participants in the data")
    expect(summary).to_contain_text("accepted n = 6 (incomplete: P007)")
