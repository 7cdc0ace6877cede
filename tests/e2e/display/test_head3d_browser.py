"""The robot display with the 3D head, in Chromium with software WebGL, fed known frames
through the server's channel: it loads offline, moves with face frames, head pose and
lip-sync, follows the study condition's renderer, reports itself, and falls back to the
2D face with a note where WebGL is missing."""

from __future__ import annotations

import queue
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi import FastAPI
from playwright.sync_api import Browser, Page, Playwright, Request, expect

from chameleons.backend.display.channel import DisplayChannel
from chameleons.backend.display.protocol import (
    Message,
    face_message,
    head_message,
    set_face_message,
)
from chameleons.settings import Settings
from tests.e2e.display.conftest import ACTOR, BOOTH, next_report, write_tone
from tests.e2e.display.test_display_browser import geometry_when, play, shapes
from tests.support.browser import wait_for_js
from tests.support.head3d import launch_webgl, open_head
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


@pytest.fixture
def settings(settings: Settings) -> Settings:
    """Adds a 4 s prompt whose lip-sync holds the mouth open from 0.2 s to 3.8 s: software
    WebGL on a busy machine can miss a short opening."""
    assert settings.prompts_dir is not None
    write_tone(settings.prompts_dir / ACTOR / "audio" / "talk.wav", 4.0)
    rows = [f"{t / 10:.1f},{1.0 if 2 <= t <= 38 else 0.0}" for t in range(41)]
    (settings.prompts_dir / ACTOR / "lipsync" / "talk.csv").write_text(
        "time,jawOpen\n" + "\n".join(rows) + "\n"
    )
    return settings


@pytest.fixture
def head_page(webgl_browser: Browser, display_url: str) -> Iterator[Page]:
    context = webgl_browser.new_context(viewport={"width": 640, "height": 480})
    page = context.new_page()
    page.set_default_timeout(30_000)
    open_head(page, display_url + "?renderer=3d")
    yield page
    context.close()


def test_the_3d_head_loads_from_this_server_only(
    webgl_browser: Browser, display_url: str, live_server: LiveServer
) -> None:
    context = webgl_browser.new_context(viewport={"width": 640, "height": 480})
    page = context.new_page()
    requested: list[str] = []
    problems: list[str] = []

    def watch(request: Request) -> None:
        requested.append(request.url)

    page.on("request", watch)
    page.on("console", lambda m: problems.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: problems.append(str(e)))
    open_head(page, display_url + "?renderer=3d")
    assert page.evaluate("window.robotDisplay.renderer().kind") == "3d"
    assert page.evaluate("window.robotDisplay.renderer().fallback") is None
    assert any(u.endswith("three.module.min.js") for u in requested)
    assert any(u.endswith("canonical_face_mesh.json") for u in requested)
    outside = [u for u in requested if not u.startswith((live_server.url, "data:", "blob:"))
               and not u.startswith(live_server.url.replace("http", "ws"))]  # fmt: skip
    assert outside == []
    assert problems == []
    context.close()


def test_face_frames_and_head_pose_move_the_3d_head(
    head_page: Page, channel: DisplayChannel
) -> None:
    channel.publish(BOOTH, face_message(shapes(), [0.0, 0.0, 0.0]))
    closed = geometry_when(head_page, "g.renderer === '3d' && g.mouthOpenPx < 1")
    channel.publish(BOOTH, face_message(shapes(jawOpen=1.0), [0.0, 0.0, 0.0]))
    opened = geometry_when(head_page, "g.mouthOpenPx > 15")
    assert opened["mouthOpenPx"] > closed["mouthOpenPx"] + 15
    channel.publish(BOOTH, head_message([30.0, 0.0, 0.0]))
    geometry_when(head_page, "g.noseX - g.centerX > 0.4 * g.scale")
    channel.publish(BOOTH, head_message([-30.0, 0.0, 0.0]))
    geometry_when(head_page, "g.centerX - g.noseX > 0.4 * g.scale")
    channel.publish(BOOTH, head_message([0.0, 0.0, 0.0]))
    level = geometry_when(head_page, "Math.abs(g.noseX - g.centerX) < 2")
    channel.publish(BOOTH, head_message([0.0, 20.0, 0.0]))  # pitch > 0 looks down
    geometry_when(head_page, f"g.noseY > {level['noseY']} + 0.15 * g.scale")


def test_the_neck_stops_at_furhat_like_limits(head_page: Page, channel: DisplayChannel) -> None:
    channel.publish(BOOTH, head_message([50.0, 0.0, 0.0]))
    at_limit = geometry_when(head_page, "g.noseX - g.centerX > 0.5 * g.scale")
    channel.publish(BOOTH, head_message([85.0, 0.0, 0.0]))
    wait_for_js(head_page, "window.robotDisplay.state().head[0] > 80")
    beyond: dict[str, Any] = head_page.evaluate(
        "new Promise(r => requestAnimationFrame(() => r(window.robotDisplay.geometry())))"
    )
    assert abs(beyond["noseX"] - at_limit["noseX"]) < 2


def test_lipsync_drives_the_3d_mouth_and_speech_is_reported(
    app: FastAPI,
    head_page: Page,
    channel: DisplayChannel,
    reports: queue.Queue[tuple[str, Message]],
) -> None:
    channel.publish(BOOTH, face_message(shapes()))
    play_id = play(app, channel, "talk", lipsync=True)
    start = next_report(reports, "speech")
    assert (start["event"], start["play_id"]) == ("start", play_id)
    geometry_when(head_page, "g.renderer === '3d' && g.mouthOpenPx > 15")
    end = next_report(reports, "speech")
    assert (end["event"], end["reason"]) == ("end", "ended")
    geometry_when(head_page, "g.mouthOpenPx < 1")


def test_the_condition_switches_between_2d_and_3d(
    head_page: Page, channel: DisplayChannel, display_url: str
) -> None:
    channel.publish(BOOTH, set_face_message("face-2", "2d"))
    wait_for_js(head_page, "window.robotDisplay.renderer().kind === '2d'")
    assert head_page.evaluate("window.robotDisplay.renderer().source") == "study"
    expect(head_page.locator("#face")).to_be_visible()
    expect(head_page.locator("#face3d")).to_be_hidden()
    channel.publish(BOOTH, set_face_message("face-3", "3d"))
    wait_for_js(head_page, "window.robotDisplay.renderer().kind === '3d'")
    geometry_when(head_page, "g.renderer === '3d'")
    expect(head_page.locator("#face3d")).to_be_visible()
    # A condition that names no renderer leaves the page's own (here the link's, 3d; after
    # a 2d condition it comes back).
    channel.publish(BOOTH, set_face_message("face-3", "2d"))
    wait_for_js(head_page, "window.robotDisplay.renderer().kind === '2d'")
    channel.publish(BOOTH, set_face_message("face-3"))
    wait_for_js(head_page, "window.robotDisplay.renderer().kind === '3d'"
                " && window.robotDisplay.renderer().source === 'link'")  # fmt: skip
    channel.publish(BOOTH, set_face_message("face-3", "3d"))
    wait_for_js(head_page, "window.robotDisplay.renderer().source === 'study'")
    # A page that opens (or reconnects) later gets the condition's renderer at once, even
    # when its link asks for the other one.
    head_page.goto(display_url + "?renderer=2d")
    wait_for_js(head_page, "window.robotDisplay.renderer().kind === '3d'"
                " && window.robotDisplay.state().face === 'face-3'")  # fmt: skip


def test_telemetry_and_debug_overlay_report_the_3d_head(
    head_page: Page,
    display_url: str,
    channel: DisplayChannel,
    reports: queue.Queue[tuple[str, Message]],
) -> None:
    telemetry = next_report(reports, "telemetry")
    while telemetry.get("renderer") != "3d" or telemetry["frame_ms"]["p50"] is None:
        telemetry = next_report(reports, "telemetry")
    assert telemetry["fps"] > 0
    # The console's and the booth check's "Robot" reads the same presence as for 2D.
    assert channel.presence(BOOTH) == (True, "display open")
    assert 0 < telemetry["frame_ms"]["p50"] <= telemetry["frame_ms"]["p95"]
    assert isinstance(telemetry["dropped_frames"], int)
    head_page.goto(display_url + "?renderer=3d&debug=1")
    wait_for_js(head_page, "document.getElementById('debug').innerText.includes('renderer 3d')")
    assert "frame" in head_page.locator("#debug").inner_text()


def test_double_click_toggles_full_screen_on_the_3d_head(head_page: Page) -> None:
    head_page.locator("#face3d").dblclick()
    wait_for_js(head_page, "document.fullscreenElement !== null")
    head_page.locator("#face3d").dblclick()
    wait_for_js(head_page, "document.fullscreenElement === null")


def test_without_webgl_the_page_shows_the_2d_face_and_says_why(
    playwright_instance: Playwright, display_url: str, reports: queue.Queue[tuple[str, Message]]
) -> None:
    browser = launch_webgl(playwright_instance, webgl=False)
    try:
        page = browser.new_page(viewport={"width": 640, "height": 480})
        open_head(page, display_url + "?renderer=3d")
        assert page.evaluate("window.robotDisplay.renderer().kind") == "2d"
        expect(page.locator("#renderer-note")).to_be_visible()
        expect(page.locator("#renderer-note")).to_contain_text("3D head unavailable")
        expect(page.locator("#face")).to_be_visible()
        geometry_when(page, "g.mouthOpenPx !== undefined")  # the 2D face paints
        telemetry = next_report(reports, "telemetry")
        while "renderer_note" not in telemetry:
            telemetry = next_report(reports, "telemetry")
        assert telemetry["renderer"] == "2d"
        assert "WebGL" in telemetry["renderer_note"]
    finally:
        browser.close()


def test_the_3d_page_reconnects_after_a_server_restart(
    app: FastAPI, live_server: LiveServer, head_page: Page, channel: DisplayChannel
) -> None:
    live_server.stop()
    wait_for_js(head_page, "!window.robotDisplay.connected()")
    with LiveServer(app, live_server.port, lifespan="off"):
        wait_for_js(head_page, "window.robotDisplay.connected()")
        channel.publish(BOOTH, face_message(shapes(jawOpen=1.0), [0.0, 0.0, 0.0]))
        geometry_when(head_page, "g.renderer === '3d' && g.mouthOpenPx > 15")
