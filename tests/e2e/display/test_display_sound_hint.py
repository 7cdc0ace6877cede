"""A browser that blocks sound until a gesture (no ``--autoplay-policy`` flag, unlike the
shared fixtures): the display shows a hint, reports a play as ``autoplay_blocked``, and after
one click hides the hint and plays.

Playwright's ``evaluate``/``wait_for_function`` run as a user gesture, which would unlock
sound: until the blocked play is reported, the test waits only on what the page reports."""

from __future__ import annotations

import queue
from collections.abc import Iterator

import pytest
from fastapi import FastAPI
from playwright.sync_api import Browser, Page, Playwright, expect

from chameleons.backend.display.channel import DisplayChannel
from chameleons.backend.display.protocol import Message
from tests.e2e.display.conftest import next_report
from tests.e2e.display.test_display_browser import play
from tests.support.browser import CHROMIUM_ARGS, chromium_path, wait_for_js

pytestmark = pytest.mark.browser
AUTOPLAY_FLAG = "--autoplay-policy=no-user-gesture-required"


@pytest.fixture
def strict_browser(playwright_instance: Playwright) -> Iterator[Browser]:
    args = [arg for arg in CHROMIUM_ARGS if arg != AUTOPLAY_FLAG]
    browser = playwright_instance.chromium.launch(
        executable_path=chromium_path(), headless=True, args=args
    )
    yield browser
    browser.close()


@pytest.fixture(params=["2d", "3d"])
def strict_page(
    request: pytest.FixtureRequest, strict_browser: Browser, display_url: str
) -> Iterator[Page]:
    """The display with either face: the click that unlocks sound works on both."""
    context = strict_browser.new_context(viewport={"width": 640, "height": 480})
    page = context.new_page()
    page.goto(f"{display_url}?renderer={request.param}")
    yield page
    context.close()


def next_speech(received: queue.Queue[tuple[str, Message]]) -> Message:
    return next_report(received, "speech")


def test_blocked_sound_shows_a_hint_reports_the_play_and_a_click_unlocks_it(
    app: FastAPI,
    strict_page: Page,
    channel: DisplayChannel,
    reports: queue.Queue[tuple[str, Message]],
) -> None:
    next_report(reports, "telemetry")  # the page is connected
    play_id = play(app, channel, "short", lipsync=False)
    blocked = next_speech(reports)
    assert (blocked["event"], blocked["play_id"], blocked["reason"]) == (
        "end", play_id, "autoplay_blocked",
    )  # fmt: skip
    hint = strict_page.locator("#sound-hint")
    expect(hint).to_be_visible()
    expect(hint).to_have_text("Tap or click once to enable the robot's voice")

    renderer = strict_page.url.rsplit("=", 1)[1]
    face = strict_page.locator("#face3d" if renderer == "3d" else "#face")
    expect(face).to_be_visible(timeout=90_000)  # a locator query, not a gesture
    face.click()
    expect(hint).to_be_hidden()
    wait_for_js(strict_page, f"window.robotDisplay.renderer().kind === '{renderer}'")
    wait_for_js(strict_page, "window.robotDisplay.audioUnlocked()")
    play_id = play(app, channel, "short", lipsync=False)
    start = next_speech(reports)
    assert (start["event"], start["play_id"]) == ("start", play_id)
    end = next_speech(reports)
    assert (end["event"], end["reason"]) == ("end", "ended")


def test_with_autoplay_allowed_the_hint_never_shows(display_page: Page) -> None:
    wait_for_js(display_page, "window.robotDisplay.audioUnlocked()")
    expect(display_page.locator("#sound-hint")).to_be_hidden()
