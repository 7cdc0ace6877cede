"""Participant video end to end, in a real Chromium with its fake camera: a consented
session runs at the booth; the booth's recording page films it with MediaRecorder and
uploads chunks through the real server as it records; the stored file is a WebM that
decodes (PyAV) for as long as it was filmed; on the PI's session page the player loads it,
and seeking it moves the cursor on the faces' plot and the timeline, and clicking the plot
seeks the video."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import av
import httpx
import pytest
from fastapi import FastAPI
from playwright.sync_api import Page, Playwright, expect
from sqlalchemy import Engine, select

from chameleons.backend.models import ParticipantVideo
from chameleons.backend.video.pages import current_video_path
from chameleons.backend.video.storage import EBML_MAGIC
from chameleons.settings import Settings
from tests.backend.test_auth import add_user
from tests.backend.video.conftest import VIDEO_STUDY
from tests.support.bots import ParticipantBot, WizardBot, staff_api, study_with_plan
from tests.support.browser import chromium_path, wait_for_js
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser
BOOTH = "booth-1"
SLOW = 60_000
FAKE_CAMERA = ["--use-fake-device-for-media-stream", "--use-fake-ui-for-media-stream"]


def wait_until(condition: Callable[[], Any], timeout: float, what: str) -> Any:
    """Poll ``condition()`` until it returns something truthy (a deadline, not a wait)."""
    deadline = time.monotonic() + timeout
    while not (value := condition()):
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.1)
    return value


def js(page: Page, expression: str) -> Any:
    return page.evaluate(expression)


def test_a_consented_session_is_filmed_and_replays_in_sync(
    playwright_instance: Playwright, live_server: LiveServer, app: FastAPI, engine: Engine,
    settings: Settings,
) -> None:  # fmt: skip
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi", "video-pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2, yaml=VIDEO_STUDY),
                                  booth=BOOTH)  # fmt: skip
        ParticipantBot(http, wizard.token).consent(True, video=True, audio=False)
        wizard.start()
        path = current_video_path(app, BOOTH)
        assert path is not None
        browser = playwright_instance.chromium.launch(executable_path=chromium_path(),
                                                      headless=True, args=FAKE_CAMERA)  # fmt: skip
        try:
            booth = browser.new_page()
            booth.goto(live_server.url + path)
            expect(booth.locator("#video-state")).to_have_attribute("data-state", "ok",
                                                                    timeout=SLOW)  # fmt: skip
            expect(booth.locator("#video-state")).to_contain_text(
                f"recording session {wizard.session_id} (no sound)"
            )
            wait_for_js(booth, "window.videoRecorder.uploaded >= 3", timeout=SLOW)
            # the session ends: the page stops and sends its last chunk
            wizard.end("technical_failure")
            expect(booth.locator("#video-state")).to_contain_text("not recording", timeout=SLOW)

            def stopped() -> ParticipantVideo | None:
                with engine.connect() as db:
                    row = db.execute(select(ParticipantVideo)).first()
                return row if row is not None and row.stopped_at is not None else None  # type: ignore[return-value]

            video = wait_until(stopped, 30, "the video's stop")
            assert js(booth, "window.videoRecorder.refused") == 0
            assert video.chunks == js(booth, "window.videoRecorder.uploaded") >= 4
            assert video.refused == 0
            assert video.audio is False
            stored = Path(settings.data_dir) / video.path
            content = stored.read_bytes()
            assert content[:4] == EBML_MAGIC
            assert len(content) == video.size_bytes
            with av.open(str(stored)) as container:
                assert "webm" in container.format.name or "matroska" in container.format.name
                frames = [f.time for f in container.decode(video=0)]
            assert len(frames) > 30
            assert frames[-1] - frames[0] > 5.0
            filmed_s = frames[-1]

            add_user(engine, "pia", "correct horse", "pi")
            context = browser.new_context(viewport={"width": 1280, "height": 900})
            page = context.new_page()
            page.set_default_timeout(SLOW)
            page.goto(f"{live_server.url}/pi/sessions/{wizard.session_id}")
            page.get_by_label("Username").fill("pia")
            page.get_by_label("Password").fill("correct horse")
            page.get_by_role("button", name="Log in").click()
            wait_for_js(page, "document.getElementById('replay').dataset.ready === 'true'",
                        timeout=SLOW)  # fmt: skip
            wait_for_js(page, "document.getElementById('replay-video').readyState >= 1",
                        timeout=SLOW)  # fmt: skip
            start_s = js(page, "window.replayPage.data.videos[0].start_s")
            # Seek the video: the plot's cursor and the timeline follow
            js(page, "document.getElementById('replay-video').currentTime = 3")
            wait_for_js(page, f"Math.abs(Number(document.getElementById('replay-curves')"
                              f".dataset.cursor) - {start_s + 3}) < 0.2", timeout=SLOW)  # fmt: skip
            assert page.locator("#timeline li.replay-now").count() == 1
            # Click the plot halfway through the video: the video goes there
            half = start_s + filmed_s / 2
            span = js(page, "window.replayPage.span")
            canvas = page.locator("#replay-curves")
            box = canvas.bounding_box()
            assert box is not None
            canvas.click(position={"x": (half - span[0]) / (span[1] - span[0]) * box["width"],
                                   "y": box["height"] / 2})  # fmt: skip
            wait_for_js(page, f"Math.abs(document.getElementById('replay-video').currentTime"
                              f" - {filmed_s / 2}) < 0.5", timeout=SLOW)  # fmt: skip
            cursor = float(canvas.get_attribute("data-cursor") or "nan")
            assert abs(cursor - half) < 0.5
            context.close()
        finally:
            browser.close()
