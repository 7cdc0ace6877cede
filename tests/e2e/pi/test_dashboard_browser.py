"""A PI walks the dashboard in Chromium: overview, a session, an export, the analysis, and
withdraws a participant by typing the code."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker, session_scope
from tests.backend.test_auth import add_user
from tests.support.factories import PopulatedStudy, populate
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


@pytest.fixture
def study(engine: Engine, settings: Any) -> PopulatedStudy:
    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, 6, rehearsals=1, recordings_dir=settings.data_dir / "recordings")
    add_user(engine, "pia", "correct horse", "pi")
    return data


def log_in(page: Page, server: LiveServer, path: str) -> None:
    page.goto(server.url + path)
    page.get_by_label("Username").fill("pia")
    page.get_by_label("Password").fill("correct horse")
    page.get_by_role("button", name="Log in").click()


# Each page of the walk is computed by the server (statistics, plots, a zip): at load 10+
# on two cores one can take well over Playwright's 5 s default, so every wait here is on
# the page's own event (a heading, a row count, a download) with a deadline this long.
SLOW = 60_000


def test_pi_walks_the_dashboard(live_server: LiveServer, page: Page, study: PopulatedStudy) -> None:
    page.set_default_timeout(SLOW)  # navigations, clicks and the download
    log_in(page, live_server, "/pi")
    expect(page.get_by_role("heading", name="Study progress")).to_be_visible(timeout=SLOW)
    expect(page.locator('[data-stat="used"]')).to_have_text("6", timeout=SLOW)
    rows = page.locator("#sessions tbody tr")
    expect(rows).to_have_count(7, timeout=SLOW)
    expect(page.locator('tr[data-participant="R001"] .badge')).to_have_text("rehearsal")

    page.get_by_role("link", name="P003", exact=True).click()
    expect(page.get_by_role("heading", name="Session of P003")).to_be_visible(timeout=SLOW)
    expect(page.locator("section.interaction")).to_have_count(3, timeout=SLOW)
    expect(page.locator("#timeline li").first).to_contain_text("session_started", timeout=SLOW)
    expect(page.locator(".recordings a")).to_have_count(6, timeout=SLOW)

    page.get_by_role("link", name="Export").click()
    page.get_by_label("Parquet").check()
    with page.expect_download(timeout=2 * SLOW) as download_info:
        page.get_by_role("button", name="Download zip").click()
    bundle = zipfile.ZipFile(io.BytesIO(Path(download_info.value.path()).read_bytes()))
    names = set(bundle.namelist())
    for table in ("participants", "interactions", "suggestions", "questionnaire", "scores"):
        assert {f"{table}.csv", f"{table}.parquet"} <= names
    assert {"events.csv", "codebook.csv", "study_config.json", "metadata.json"} <= names
    assert bundle.read("scores.csv").decode().count("\n") == 1 + 6 * 3  # no rehearsal

    page.get_by_role("link", name="Analysis").click()
    expect(page.locator("#table1 tbody tr")).to_have_count(4, timeout=SLOW)
    expect(page.locator("#friedman tbody tr")).to_have_count(4, timeout=SLOW)
    expect(page.locator("#latex")).to_contain_text("\\begin{tabular}", timeout=SLOW)
    images = page.locator("#plots img")
    expect(images).to_have_count(4, timeout=SLOW)
    for index in range(4):
        image = images.nth(index)
        image.scroll_into_view_if_needed()
        # Four plots drawn at once on a busy machine: wait for them, not for 5 s.
        expect(image).to_have_js_property("complete", True, timeout=SLOW)
        assert image.evaluate("img => img.naturalWidth") > 100, "a plot did not load"


def test_pi_withdraws_a_participant_by_typing_the_code(
    live_server: LiveServer, page: Page, study: PopulatedStudy
) -> None:
    log_in(page, live_server, "/pi")
    page.locator('tr[data-participant="P002"]').get_by_role("link", name="Withdraw…").click()
    expect(page.get_by_role("heading", name="Withdraw participant P002")).to_be_visible()
    page.get_by_label("Type the participant code").fill("P002")
    page.get_by_role("button", name="Delete all data of P002").click()
    expect(page.get_by_role("heading", name="P002 was withdrawn")).to_be_visible()
    expect(page.locator("#removed")).to_contain_text("6 face recording files of P002")
    expect(page.locator("#not-removed")).to_contain_text("Backups and copies of the database")
    page.get_by_role("link", name="Back to the overview").click()
    expect(page.locator('tr[data-participant="P002"]')).to_have_count(0)
    expect(page.locator('[data-stat="withdrawn"]')).to_have_text("1")
    assert not any(p.exists() for p in study.recording_paths[6:12])


def test_pi_excludes_a_participant_and_the_analysis_says_so(
    live_server: LiveServer, page: Page, study: PopulatedStudy
) -> None:
    log_in(page, live_server, "/pi")
    page.locator('tr[data-participant="P004"]').get_by_role("link", name="Exclude…").click()
    expect(page.get_by_role("heading", name="Exclude participant P004")).to_be_visible()
    page.get_by_label("Reason").fill("misunderstood the task")
    page.get_by_role("button", name="Exclude P004").click()
    expect(page.get_by_role("status")).to_contain_text("P004 is excluded from the analysis")
    row = page.locator('tr[data-participant="P004"]')
    expect(row.locator(".badge.excluded")).to_have_text("excluded")
    expect(row.locator('[data-flag="excluded"]')).to_be_visible()
    expect(page.locator('[data-stat="excluded"]')).to_have_text("1")
    page.goto(live_server.url + "/pi/analysis")
    expect(page.locator("#left-out")).to_contain_text("P004: excluded by the PI: misunderstood")
    expect(page.locator("#analysis-summary")).to_contain_text("6 participants in the data")
    page.locator('tr[data-participant="P004"]').count()  # the analysis has no session rows
    page.goto(live_server.url + "/pi")
    page.locator('tr[data-participant="P004"]').get_by_role("button", name="Include again").click()
    expect(page.get_by_role("status")).to_contain_text("P004 is included in the analysis again")
