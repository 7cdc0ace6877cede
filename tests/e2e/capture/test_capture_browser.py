"""The capture page in a real Chromium whose fake camera shows a real face photo, turned
15 degrees counter-clockwise: MediaPipe's face mesh (served by this server from the
vendored package) finds the face, the page streams the landmarks over its WebSocket, the
server relays them over ZeroMQ to a real worker, which maps them and publishes them as its
``webcam-browser`` capture source with the head's roll positive (the image-right side of
the head up). Software rendering is slow: a few frames, waits on events with generous
deadlines."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from playwright.sync_api import Playwright, expect

from chameleons.backend.app import create_app
from chameleons.backend.capture import current_capture_path
from chameleons.settings import Settings
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.support.browser import wait_for_js
from tests.support.faces import Motion, scene
from tests.support.fake_camera import camera_args, chromium, write_y4m
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser
BOOTH = "booth-1"
ROLL = 15.0


def wait_until(condition: Callable[[], Any], timeout: float, what: str) -> Any:
    """Poll ``condition()`` until it returns something truthy (a deadline, not a wait)."""
    deadline = time.monotonic() + timeout
    while not (value := condition()):
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)
    return value


@pytest.fixture
def served(settings: Settings, tmp_path: Path) -> Iterator[tuple[LiveServer, FastAPI, Worker]]:
    settings = settings.model_copy(update={
        "bridge_enabled": True, "worker_command_endpoint": "tcp://127.0.0.1:*",
        "worker_telemetry_endpoint": "tcp://127.0.0.1:*", "keys_dir": tmp_path / "keys",
    })  # fmt: skip
    app = create_app(settings)
    with LiveServer(app) as server:
        bridge = app.state.bridge
        worker = Worker(WorkerConfig(
            booth=BOOTH, driver="virtual", data_dir=tmp_path / "worker",
            command_endpoint=bridge.command_endpoint,
            telemetry_endpoint=bridge.telemetry_endpoint,
            livelink_port=None, facecapturex_port=None,
        )).start()  # fmt: skip
        try:
            wait_until(lambda: BOOTH in bridge.workers(), 20, "the worker's hello")
            yield server, app, worker
        finally:
            worker.stop()


def test_the_capture_page_streams_a_real_face_to_the_worker(
    playwright_instance: Playwright, served: tuple[LiveServer, FastAPI, Worker], tmp_path: Path
) -> None:
    server, app, worker = served
    video = write_y4m(tmp_path / "face.y4m",
                      [scene("grace_hopper", Motion(angle=ROLL))] * 4)  # fmt: skip
    browser = playwright_instance.chromium.launch(executable_path=chromium(), headless=True,
                                         args=camera_args(video))  # fmt: skip
    try:
        page = browser.new_page()
        path = current_capture_path(app, BOOTH)
        assert path is not None
        page.goto(server.url + path)
        expect(page.get_by_role("heading", name=f"Webcam capture: {BOOTH}")).to_be_visible()
        wait_for_js(page, "window.capturePage.sent >= 3", timeout=120_000)
        expect(page.locator("#face-state")).to_have_attribute("data-state", "ok")
        receiver = worker.browser
        assert receiver is not None
        snapshot = wait_until(
            lambda: (s := receiver.snapshot())["frames"] >= 3 and s, 60, "frames at the worker"
        )
        assert snapshot["connected"] is True
        assert snapshot["camera"], snapshot  # the fake camera's label
        yaw, pitch, roll = snapshot["head"]
        assert abs(roll - ROLL) < 5.0, snapshot["head"]  # right sign, within a few degrees
        assert abs(yaw) < 10.0, snapshot["head"]
        assert abs(pitch) < 15.0, snapshot["head"]
        # The worker's status (what the console and the booth check read) names the source.
        ingest = worker.ingest_stats()
        assert ingest["source"] == "webcam-browser"
        expect(page.locator("#worker-state")).to_have_attribute("data-state", "ok")
        page.close()
        wait_until(lambda: not receiver.snapshot()["connected"], 30, "the page's goodbye")
    finally:
        browser.close()
