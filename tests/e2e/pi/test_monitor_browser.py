"""In Chromium: the PI's booths monitor shows two booths live (a running session whose phone
and worker are gone is an alarm; a booth waiting for its participant only warns), follows
the wizard's steps within its one-second refresh, and is for PIs only; for a study that
films, each booth's *Participant video* chip as the console shows it, from the recording
page's requests through the real API."""

from __future__ import annotations

import re
import time

import httpx
import pytest
from fastapi import FastAPI
from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from chameleons.backend.video.pages import current_video_path
from chameleons.backend.wizard import video_health
from tests.backend.test_auth import add_user
from tests.backend.video.conftest import VIDEO_STUDY
from tests.backend.video.test_video_api import FIRST
from tests.support.bots import ParticipantBot, WizardBot, staff_api, study_with_plan
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


def log_in_as_pi(page: Page, live_server: LiveServer, path: str) -> None:
    page.goto(f"{live_server.url}/login?next={path}")
    page.get_by_label("Username").fill("pia")
    page.get_by_label("Password").fill("correct horse battery")
    page.get_by_role("button", name="Log in").click()
    expect(page.get_by_role("heading", name="Booths")).to_be_visible()


def test_the_monitor_shows_booths_live_with_alarms(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    http = httpx.Client(base_url=live_server.url, timeout=30)
    pi = staff_api(http, engine, "pi")
    study_id = study_with_plan(pi, participants=4)
    first = WizardBot.create(pi, study_id, booth="booth-1")
    first.start()
    WizardBot.create(pi, study_id, booth="booth-2")
    add_user(engine, "pia", "correct horse battery", "pi")
    log_in_as_pi(page, live_server, "/pi/monitor")

    one, two = page.locator("[data-booth='booth-1']"), page.locator("[data-booth='booth-2']")
    expect(one).to_have_class("booth alarm")
    expect(one.locator(".problems")).to_contain_text("Phone: not connected during the session")
    expect(one.locator(".problems")).to_contain_text("Worker")
    expect(two).to_have_class("booth warn")  # waiting for its participant: no alarm
    expect(page.locator("#monitor-alarms")).to_have_text("1 alarm")
    expect(one.locator(".who")).to_contain_text("running")
    # The booth check of each booth, for its open session (after the page's own redraw).
    check = one.locator("a.booth-check-link")
    expect(check).to_have_attribute("href", f"/booths/booth-1/check?session_id={first.session_id}")
    check.click()
    expect(page.get_by_role("heading", name="Booth check: booth-1")).to_be_visible()
    expect(page.locator("#booth-check")).to_contain_text(f"For session {first.session_id}")
    page.go_back()

    first.advance(1, "discussion")  # the page follows without a reload
    expect(one.locator(".who")).to_contain_text("interaction 1 · discussion")
    expect(one.locator(".recent li").first).to_contain_text("Interaction 1: pending → discussion")
    WizardBot.create(pi, study_id, booth="booth-3")
    expect(page.locator("[data-booth='booth-3']")).to_be_visible()
    expect(page.locator(".booth")).to_have_count(3)

    wizard = staff_api(http, engine, "wizard", name="just-a-wizard")
    assert wizard.http.get("/api/pi/monitor").status_code == 403
    http.close()


def test_the_monitor_shows_the_participant_video_chip(
    live_server: LiveServer, app: FastAPI, page: Page, engine: Engine,
    monkeypatch: pytest.MonkeyPatch,
) -> None:  # fmt: skip
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        study_id = study_with_plan(pi, participants=2, yaml=VIDEO_STUDY)
        wizard = WizardBot.create(pi, study_id, booth="booth-1")
        ParticipantBot(http, wizard.token).consent(True, video=True)
        monkeypatch.setattr(video_health, "SILENT_AFTER_S", 0.0)  # no start's grace
        wizard.start()
        add_user(engine, "pia", "correct horse battery", "pi")
        log_in_as_pi(page, live_server, f"/pi/monitor?study={study_id}")
        chip = page.locator("[data-booth='booth-1'] .chip[title='video']")
        expect(chip).to_contain_text("Participant video")
        expect(chip).to_contain_text("recording page is not open/recording: no chunk yet")
        expect(chip).to_have_class("chip degraded")

        # The recording page's requests: a video of the session and two chunks.
        video_path = current_video_path(app, "booth-1")
        assert video_path is not None
        key = {"X-Booth-Key": video_path.rsplit("/", 1)[-1]}
        api = "/api/video/booth-1"
        started = http.post(f"{api}/videos", headers=key, json={
            "session_id": wizard.session_id, "mime_type": "video/webm;codecs=vp8",
            "audio": False,
            "clock": {"start_ms": 0.0, "offset_ms": time.time() * 1000, "rtt_ms": 2.0},
        })  # fmt: skip
        assert started.status_code == 201, started.text
        video_id = started.json()["video_id"]
        monkeypatch.setattr(video_health, "SILENT_AFTER_S", 600.0)  # green while the test looks
        for seq, data in enumerate((FIRST, b"cluster 1")):
            stored = http.post(f"{api}/videos/{video_id}/chunks/{seq}", content=data,
                               headers={**key, "Content-Type": "video/webm"})  # fmt: skip
            assert stored.status_code == 200, stored.text
        expect(chip).to_have_class("chip ok")
        expect(chip).to_have_text(
            re.compile(r"Participant video recording: 2 chunks, last \d+ s ago$"))  # fmt: skip

        # The page falls silent: amber with the count, and no alarm line for the video.
        monkeypatch.setattr(video_health, "SILENT_AFTER_S", 0.5)
        expect(chip).to_have_class("chip degraded")
        expect(chip).to_have_text(re.compile(
            r"recording page is not open/recording: 2 chunks, last \d+ s ago$"))  # fmt: skip
        expect(page.locator("[data-booth='booth-1'] .problems")).not_to_contain_text("video")
