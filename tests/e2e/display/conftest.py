"""Fixtures for the robot display in a real Chromium: a prompts folder with a short tone,
the booth's display link, and a recorder of what pages report back."""

from __future__ import annotations

import queue
import secrets
import shutil
import wave
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fastapi import FastAPI
from playwright.sync_api import Browser, Page, Playwright

from chameleons.backend.app import create_app
from chameleons.backend.display.channel import DisplayChannel, get_display_channel
from chameleons.backend.display.protocol import Message
from chameleons.backend.display.tokens import display_path, signing_key
from chameleons.settings import Settings
from tests.support.browser import wait_for_js
from tests.support.head3d import launch_webgl
from tests.support.live_server import LiveServer

BOOTH = "booth-1"
ACTOR = "t1"


def write_tone(path: Path, seconds: float, rate: int = 16000) -> None:
    """A 440 Hz tone as 16-bit mono WAV."""
    path.parent.mkdir(parents=True, exist_ok=True)
    t = np.arange(int(seconds * rate)) / rate
    samples = (8000 * np.sin(2 * np.pi * 440 * t)).astype("<i2")
    with wave.open(str(path), "wb") as out:
        out.setnchannels(1)
        out.setsampwidth(2)
        out.setframerate(rate)
        out.writeframes(samples.tobytes())


@pytest.fixture
def settings(settings: Settings, tmp_path: Path) -> Settings:
    prompts = tmp_path / "prompts"
    write_tone(prompts / ACTOR / "audio" / "short.wav", 0.6)
    write_tone(prompts / ACTOR / "audio" / "long.wav", 20.0)
    lipsync = prompts / ACTOR / "lipsync" / "short.csv"
    lipsync.parent.mkdir(parents=True)
    # The mouth is wide open from 0.1 s to 0.5 s.
    rows = [f"{t / 30:.3f},{1.0 if 3 <= t <= 15 else 0.0}" for t in range(19)]
    lipsync.write_text("time,jawOpen\n" + "\n".join(rows) + "\n")
    return settings.model_copy(update={"prompts_dir": prompts})


@pytest.fixture
def channel(app: FastAPI) -> DisplayChannel:
    return get_display_channel(app)


@pytest.fixture
def reports(channel: DisplayChannel) -> Iterator[queue.Queue[tuple[str, Message]]]:
    """Everything the pages report (speech events, telemetry), in arrival order."""
    received: queue.Queue[tuple[str, Message]] = queue.Queue()

    def listener(booth: str, message: Message) -> None:
        received.put((booth, message))

    channel.add_listener(listener)
    yield received
    channel.remove_listener(listener)


@pytest.fixture
def display_url(live_server: LiveServer, app: FastAPI) -> str:
    return live_server.url + display_path(signing_key(app), BOOTH)


@pytest.fixture
def display_page(page: Page, display_url: str) -> Page:
    page.set_viewport_size({"width": 640, "height": 480})
    page.goto(display_url)
    wait_for_js(page, "window.robotDisplay && window.robotDisplay.connected()")
    return page


def next_report(
    received: queue.Queue[tuple[str, Message]], kind: str, timeout: float = 10.0
) -> Message:
    """The next report of type ``kind`` (others are skipped)."""
    while True:
        _booth, message = received.get(timeout=timeout)
        if message.get("type") == kind:
            return message


@pytest.fixture(scope="module")
def module_server(
    tmp_path_factory: pytest.TempPathFactory, sqlite_template: Path
) -> Iterator[tuple[FastAPI, LiveServer]]:
    """One app and live server for a whole module (tests that share one slow page load)."""
    folder = tmp_path_factory.mktemp("display-module")
    shutil.copyfile(sqlite_template, folder / "db.sqlite3")
    settings = Settings(database_url=f"sqlite:///{folder / 'db.sqlite3'}", data_dir=folder / "data",
                        secret_key=secrets.token_urlsafe(32), bridge_enabled=False,
                        _env_file=None)  # fmt: skip
    app = create_app(settings)
    server = LiveServer(app).start()
    yield app, server
    server.stop()
    app.state.engine.dispose()


@pytest.fixture(scope="module")
def display_url_module(module_server: tuple[FastAPI, LiveServer]) -> str:
    app, server = module_server
    return server.url + display_path(signing_key(app), BOOTH)


@pytest.fixture(scope="module")
def webgl_browser(playwright_instance: Playwright) -> Iterator[Browser]:
    """Chromium with software WebGL (SwiftShader), for the 3D head."""
    browser = launch_webgl(playwright_instance)
    yield browser
    browser.close()
