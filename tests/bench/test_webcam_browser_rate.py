"""The browser path's rate, measured (issue 29's bench, not a goal): the capture page in
headless Chromium (software rendering: SwiftShader, no GPU) tracks Chromium's fake camera
(30 fps, a real face photo) with the vendored MediaPipe wasm and streams to a real worker.
Prints the page's frames per second and the worker's view of the stream; the assertions
only say the path runs. ``pytest -m browser -s tests/bench/test_webcam_browser_rate.py``."""

from __future__ import annotations

import shutil
import time
from pathlib import Path

import pytest
from fastapi import FastAPI
from playwright.sync_api import Playwright

from chameleons.backend.capture import current_capture_path
from chameleons.worker.runtime import Worker
from tests.e2e.capture.test_capture_browser import BOOTH, served, wait_until
from tests.support.browser import wait_for_js
from tests.support.faces import Motion, scene
from tests.support.fake_camera import camera_args, chromium, write_y4m
from tests.support.live_server import LiveServer

pytestmark = [pytest.mark.browser, pytest.mark.slow]
__all__ = ["served"]  # the fixture, shared with the capture page's own browser test
SECONDS = 15.0


@pytest.fixture
def database_url(sqlite_template: Path, tmp_path: Path) -> str:
    """One backend (SQLite) is enough for a browser measurement (as in tests/e2e)."""
    path = tmp_path / "browser.sqlite3"
    shutil.copyfile(sqlite_template, path)
    return f"sqlite:///{path}"


def test_the_capture_page_frame_rate_in_software_rendering(
    playwright_instance: Playwright, served: tuple[LiveServer, FastAPI, Worker], tmp_path: Path
) -> None:
    server, app, worker = served
    video = write_y4m(tmp_path / "face.y4m", [scene("grace_hopper", Motion(angle=10))] * 4)
    browser = playwright_instance.chromium.launch(executable_path=chromium(), headless=True,
                                                  args=camera_args(video))  # fmt: skip
    try:
        page = browser.new_page()
        path = current_capture_path(app, BOOTH)
        assert path is not None
        page.goto(server.url + path)
        wait_for_js(page, "window.capturePage.sent >= 3", timeout=120_000)
        receiver = worker.browser
        assert receiver is not None
        sent0, frames0 = page.evaluate("window.capturePage.sent"), receiver.snapshot()["frames"]
        started = time.monotonic()
        time.sleep(SECONDS)  # a measuring window, not a wait for an event
        wall = time.monotonic() - started
        sent = page.evaluate("window.capturePage.sent") - sent0
        snapshot = wait_until(lambda: receiver.snapshot(), 5, "the receiver's snapshot")
        frames = snapshot["frames"] - frames0
        shown = page.locator("#fps").text_content()
        print(f"\npage sent {sent / wall:.2f} fps; worker mapped {frames / wall:.2f} fps; "
              f"the page's chip: {shown}; receiver: {snapshot}")  # fmt: skip
        assert sent > 0
        page.close()
    finally:
        browser.close()
