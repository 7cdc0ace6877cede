"""In Chromium: the console's *Participant video* chip for a consented session of a study
that films (the shipped ``embodiment`` study), while the recording page's requests go
through the real API. It says the page is not sending yet, turns green with the chunk
count once chunks come, counts the seconds since the last chunk on by itself, and turns
amber when the page falls silent."""

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
from tests.backend.video.conftest import VIDEO_STUDY
from tests.backend.video.test_video_api import FIRST
from tests.e2e.wizard.conftest import log_in
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, study_with_plan
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser
BOOTH = "booth-1"
API = f"/api/video/{BOOTH}"


def test_the_video_chip_follows_the_recording_page(
    live_server: LiveServer, app: FastAPI, staff: StaffApi, http: httpx.Client, page: Page,
    engine: Engine, monkeypatch: pytest.MonkeyPatch,
) -> None:  # fmt: skip
    wizard = WizardBot.create(staff, study_with_plan(staff, participants=2, yaml=VIDEO_STUDY),
                              booth=BOOTH)  # fmt: skip
    ParticipantBot(http, wizard.token).consent(True, video=True)
    monkeypatch.setattr(video_health, "SILENT_AFTER_S", 0.0)  # no start's grace
    wizard.start()
    path = f"/wizard/sessions/{wizard.session_id}"
    log_in(page, live_server.url, engine, path)
    page.wait_for_url(f"**{path}")
    chip = page.locator("#health .chip[data-check='video']")
    expect(chip).to_contain_text("Participant video")
    expect(chip).to_contain_text("recording page is not open/recording: no chunk yet")
    expect(chip).to_have_attribute("data-state", "degraded")

    # The recording page's requests: a video of the session and two chunks.
    video_path = current_video_path(app, BOOTH)
    assert video_path is not None
    key = {"X-Booth-Key": video_path.rsplit("/", 1)[-1]}
    now_ms = time.time() * 1000
    started = http.post(f"{API}/videos", headers=key, json={
        "session_id": wizard.session_id, "mime_type": "video/webm;codecs=vp8", "audio": False,
        "clock": {"start_ms": 0.0, "offset_ms": now_ms, "rtt_ms": 2.0}})  # fmt: skip
    assert started.status_code == 201, started.text
    video_id = started.json()["video_id"]
    monkeypatch.setattr(video_health, "SILENT_AFTER_S", 600.0)  # green while the test looks
    for seq, data in enumerate((FIRST, b"cluster 1")):
        stored = http.post(f"{API}/videos/{video_id}/chunks/{seq}", content=data,
                           headers={**key, "Content-Type": "video/webm"})  # fmt: skip
        assert stored.status_code == 200, stored.text
    expect(chip).to_have_attribute("data-state", "ok")
    expect(chip).to_have_text(re.compile(r"recording: 2 chunks, last \d+ s ago$"))
    # The seconds since the last chunk count on in the page (no health message needed).
    shown = chip.text_content() or ""
    expect(chip).not_to_have_text(shown)
    expect(chip).to_have_text(re.compile(r"recording: 2 chunks, last \d+ s ago$"))

    # The page falls silent: amber, with the count and the seconds since the last chunk.
    monkeypatch.setattr(video_health, "SILENT_AFTER_S", 0.5)
    expect(chip).to_have_attribute("data-state", "degraded")
    expect(chip).to_have_text(re.compile(
        r"video consented but the booth's recording page is not open/recording: 2 chunks, "
        r"last \d+ s ago · degraded$"))  # fmt: skip
    expect(page.locator("#health .alarm")).not_to_contain_text("Participant video")
