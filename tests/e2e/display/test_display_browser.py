"""The robot display in a real Chromium, fed known frames through the server's channel."""

from __future__ import annotations

import io
import queue
import time
from typing import Any

import numpy as np
import pytest
from fastapi import FastAPI
from PIL import Image
from playwright.sync_api import Page

from chameleons.backend.display.channel import DisplayChannel
from chameleons.backend.display.media import media_path
from chameleons.backend.display.protocol import (
    FACE_IDS,
    Message,
    face_message,
    head_message,
    play_audio_message,
    set_face_message,
    stop_audio_message,
)
from chameleons.backend.display.tokens import signing_key
from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES
from tests.e2e.display.conftest import ACTOR, BOOTH, next_report
from tests.support.browser import wait_for_js
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser
TWO_PAINTS = "new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))"


def shapes(**values: float) -> list[float]:
    out = [0.0] * N_BLENDSHAPES
    for name, value in values.items():
        out[BLENDSHAPE_INDEX[name]] = value
    return out


def geometry_when(page: Page, condition: str) -> dict[str, Any]:
    """Wait until ``condition`` (JS over ``g``, the last painted geometry) holds."""
    wait_for_js(
        page,
        f"(() => {{ const g = window.robotDisplay.geometry(); return g && ({condition}); }})()",
    )
    result: dict[str, Any] = page.evaluate("window.robotDisplay.geometry()")
    return result


def canvas_pixels(page: Page) -> np.ndarray:
    png = page.locator("#face").screenshot()
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def test_jaw_open_opens_the_mouth(display_page: Page, channel: DisplayChannel) -> None:
    channel.publish(BOOTH, face_message(shapes()))
    closed = geometry_when(display_page, "g.mouthOpenPx < 1")
    closed_pixels = canvas_pixels(display_page)
    channel.publish(BOOTH, face_message(shapes(jawOpen=1.0)))
    opened = geometry_when(display_page, "g.mouthOpenPx > 40")
    assert opened["mouthOpenPx"] > closed["mouthOpenPx"] + 40
    opened_pixels = canvas_pixels(display_page)
    # The open mouth's inside is dark red: count such pixels in the middle of the face.
    height, width = opened_pixels.shape[:2]
    middle = (slice(int(height * 0.5), int(height * 0.9)), slice(width // 3, 2 * width // 3))

    def dark(pixels: np.ndarray) -> int:
        r, g, b = (pixels[middle][..., k] for k in range(3))
        return int(((r + g + b < 250) & (r > g + 20) & (r > b)).sum())

    assert dark(opened_pixels) > dark(closed_pixels) + 300


def test_smile_and_pucker_change_the_mouth_width(
    display_page: Page, channel: DisplayChannel
) -> None:
    channel.publish(BOOTH, face_message(shapes()))
    neutral = geometry_when(display_page, "g.mouthOpenPx < 1")["mouthWidthPx"]
    channel.publish(BOOTH, face_message(shapes(mouthStretchLeft=1.0, mouthStretchRight=1.0)))
    geometry_when(display_page, f"g.mouthWidthPx > {neutral} * 1.2")
    channel.publish(BOOTH, face_message(shapes(mouthPucker=1.0)))
    geometry_when(display_page, f"g.mouthWidthPx < {neutral} * 0.7")


def test_head_yaw_turns_the_head(display_page: Page, channel: DisplayChannel) -> None:
    channel.publish(BOOTH, head_message([0.0, 0.0, 0.0]))
    straight = geometry_when(display_page, "Math.abs(g.noseX - g.centerX) < 1")
    channel.publish(BOOTH, head_message([30.0, 0.0, 0.0]))
    right = geometry_when(display_page, "g.noseX - g.centerX > 0.4 * g.scale")
    channel.publish(BOOTH, head_message([-30.0, 0.0, 0.0]))
    left = geometry_when(display_page, "g.centerX - g.noseX > 0.4 * g.scale")
    assert left["noseX"] < straight["noseX"] < right["noseX"]
    channel.publish(BOOTH, head_message([0.0, 20.0, 0.0]))  # pitch > 0 looks down
    geometry_when(display_page, f"g.noseY > {straight['noseY']} + 0.2 * g.scale")


def test_motion_is_interpolated_between_frames(display_page: Page, channel: DisplayChannel) -> None:
    """The page paints positions between two frames, not a jump."""
    channel.publish(BOOTH, head_message([0.0, 0.0, 0.0]))
    geometry_when(display_page, "Math.abs(g.noseX - g.centerX) < 1")
    display_page.evaluate(
        """() => { window.__noses = [];
          const tick = () => { const g = window.robotDisplay.geometry();
            window.__noses.push(g.noseX - g.centerX); requestAnimationFrame(tick); };
          requestAnimationFrame(tick); }"""
    )
    # Sent 200 ms apart by the sender's clock, arriving together: a smooth turn anyway.
    sent = time.monotonic()
    channel.publish(BOOTH, head_message([0.0, 0.0, 0.0], sent=sent))
    channel.publish(BOOTH, head_message([30.0, 0.0, 0.0], sent=sent + 0.2))
    geometry_when(display_page, "g.noseX - g.centerX > 0.4 * g.scale")
    noses: list[float] = display_page.evaluate("window.__noses")
    final = noses[-1]
    between = [x for x in noses if 0.05 * final < x < 0.95 * final]
    assert between, f"no intermediate positions painted: {noses}"


def test_the_four_faces_differ(display_page: Page, channel: DisplayChannel) -> None:
    channel.publish(BOOTH, face_message(shapes(), [0.0, 0.0, 0.0]))
    pictures = {}
    for face in FACE_IDS:
        channel.publish(BOOTH, set_face_message(face))
        wait_for_js(display_page, f"window.robotDisplay.state().face === '{face}'")
        display_page.evaluate(
            "new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))"
        )
        pictures[face] = canvas_pixels(display_page)
    for i, a in enumerate(FACE_IDS):
        for b in FACE_IDS[i + 1 :]:
            changed = (np.abs(pictures[a] - pictures[b]).sum(axis=2) > 60).mean()
            assert changed > 0.05, f"{a} and {b} differ in only {changed:.1%} of the pixels"


def test_a_reconnecting_page_gets_the_current_face(
    page: Page, display_url: str, channel: DisplayChannel
) -> None:
    channel.publish(BOOTH, set_face_message("face-3"))
    page.goto(display_url)
    wait_for_js(page, "window.robotDisplay.state().face === 'face-3'")


def test_page_reconnects_after_a_server_restart(
    app: FastAPI, live_server: LiveServer, display_page: Page, channel: DisplayChannel
) -> None:
    live_server.stop()
    wait_for_js(display_page, "!window.robotDisplay.connected()")
    with LiveServer(app, live_server.port, lifespan="off"):
        wait_for_js(display_page, "window.robotDisplay.connected()")
        channel.publish(BOOTH, set_face_message("face-2"))
        wait_for_js(display_page, "window.robotDisplay.state().face === 'face-2'")


def play(app: FastAPI, channel: DisplayChannel, name: str, *, lipsync: bool) -> str:
    key = signing_key(app)
    url = media_path(key, ACTOR, f"audio/{name}.wav")
    curves = media_path(key, ACTOR, f"lipsync/{name}.csv") if lipsync else None
    channel.publish(BOOTH, play_audio_message(f"{name}#1", url, prompt_id=name,
                                              lipsync_url=curves))  # fmt: skip
    return f"{name}#1"


def test_audio_plays_with_lipsync_and_reports_start_and_end(
    app: FastAPI,
    display_page: Page,
    channel: DisplayChannel,
    reports: queue.Queue[tuple[str, Message]],
) -> None:
    channel.publish(BOOTH, face_message(shapes()))
    play_id = play(app, channel, "short", lipsync=True)
    start = next_report(reports, "speech")
    assert (start["event"], start["play_id"], start["prompt_id"]) == ("start", play_id, "short")
    assert start["audio_delay_ms"] >= 0
    # The lip-sync curves open the mouth while the tone plays, without any face frame.
    geometry_when(display_page, "g.mouthOpenPx > 40")
    end = next_report(reports, "speech")
    assert (end["event"], end["play_id"], end["reason"]) == ("end", play_id, "ended")
    geometry_when(display_page, "g.mouthOpenPx < 1")


def test_stop_ends_the_audio(
    app: FastAPI,
    display_page: Page,
    channel: DisplayChannel,
    reports: queue.Queue[tuple[str, Message]],
) -> None:
    play_id = play(app, channel, "long", lipsync=False)
    assert next_report(reports, "speech")["event"] == "start"
    assert display_page.evaluate("window.robotDisplay.speaking()")
    channel.publish(BOOTH, stop_audio_message(play_id))
    end = next_report(reports, "speech")
    assert (end["event"], end["reason"]) == ("end", "stopped")


def test_a_new_prompt_interrupts_the_one_playing(
    app: FastAPI, display_page: Page, channel: DisplayChannel,
    reports: queue.Queue[tuple[str, Message]],
) -> None:  # fmt: skip
    first = play(app, channel, "long", lipsync=False)
    assert next_report(reports, "speech")["event"] == "start"
    second = play(app, channel, "short", lipsync=False)
    events = [next_report(reports, "speech") for _ in range(3)]
    assert [(e["play_id"], e["event"]) for e in events] == [
        (first, "end"), (second, "start"), (second, "end"),
    ]  # fmt: skip
    assert events[0]["reason"] == "interrupted"
    assert events[2]["reason"] == "ended"


def test_missing_audio_is_reported_as_an_error_end(
    app: FastAPI, display_page: Page, channel: DisplayChannel,
    reports: queue.Queue[tuple[str, Message]],
) -> None:  # fmt: skip
    play(app, channel, "missing", lipsync=False)
    end = next_report(reports, "speech")
    assert (end["event"], end["reason"]) == ("end", "error")


def test_page_reports_frame_rate_and_latency(
    display_page: Page, channel: DisplayChannel, reports: queue.Queue[tuple[str, Message]]
) -> None:
    for k in range(10):
        channel.publish(BOOTH, face_message(shapes(jawOpen=k / 10)))
    telemetry = next_report(reports, "telemetry")
    while telemetry["paint_latency_ms"]["p50"] is None:  # a report from before the frames
        telemetry = next_report(reports, "telemetry")
    assert telemetry["fps"] > 5
    assert 0 <= telemetry["paint_latency_ms"]["p50"] < 1000
    assert telemetry["face"] == "face-1"
    assert channel.telemetry(BOOTH) is not None


def test_page_shows_no_text_but_a_debug_overlay_on_request(
    display_page: Page, display_url: str
) -> None:
    assert display_page.evaluate("document.body.innerText.trim()") == ""
    display_page.goto(display_url + "?debug=1")
    wait_for_js(display_page, "document.getElementById('debug').innerText.includes('fps')")
