"""A lab's own head: a GLB built here with three ARKit-named morph targets in three of the
spellings found in the wild loads on the display page, the page reports the 49 shapes it
lacks (debug overlay, console, telemetry) and renders it like the built-in head."""

from __future__ import annotations

import queue

import numpy as np
import pytest
from playwright.sync_api import Browser, ConsoleMessage

from chameleons.backend.display.protocol import Message
from chameleons.backend.display.renderers import heads_dir
from chameleons.settings import Settings
from chameleons.worker.frames import BLENDSHAPE_NAMES
from tests.e2e.display.conftest import next_report
from tests.support.browser import wait_for_js
from tests.support.head3d import changed, open_head, sphere_head, stills

pytestmark = pytest.mark.browser
# Spellings: Furhat's UPPER_SNAKE behind a prefix, Swift's _L, PascalCase. Each bump moves
# the sphere's outline (the file has no normal targets, so a bump facing the camera would
# not change the shading); +x is the face's own left.
TARGETS = {
    "head.JAW_OPEN": ((0.0, -10.0, 0.0), (0.0, -4.0, 0.0), 4.0),
    "eyeBlink_L": ((10.0, 3.0, 0.0), (3.0, 0.0, 0.0), 3.0),
    "MouthSmileLeft": ((7.0, -7.0, 0.0), (2.0, -2.0, 0.0), 3.0),
}
PROVIDED = {"jawOpen", "eyeBlinkLeft", "mouthSmileLeft"}


@pytest.fixture
def settings(settings: Settings) -> Settings:
    folder = heads_dir(settings)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "lab-head.glb").write_bytes(sphere_head(TARGETS))
    return settings


def test_a_labs_head_loads_and_reports_what_it_lacks(
    webgl_browser: Browser, display_url: str, reports: queue.Queue[tuple[str, Message]]
) -> None:
    page = webgl_browser.new_page(viewport={"width": 640, "height": 480})
    warnings: list[str] = []

    def console(message: ConsoleMessage) -> None:
        if message.type == "warning":
            warnings.append(message.text)

    page.on("console", console)
    open_head(page, display_url + "?renderer=3d&head=lab-head.glb&debug=1")
    state = page.evaluate("window.robotDisplay.renderer()")
    assert (state["kind"], state["fallback"]) == ("3d", None)
    expected = [n for n in BLENDSHAPE_NAMES if n not in PROVIDED]
    assert state["missing"] == expected
    wait_for_js(page, "document.getElementById('debug').innerText.includes('head lacks 49')")
    assert any("lacks 49 ARKit shapes" in w and "browInnerUp" in w for w in warnings)
    telemetry = next_report(reports, "telemetry")
    while "head_missing" not in telemetry:
        telemetry = next_report(reports, "telemetry")
    assert telemetry["head_missing"] == expected
    assert telemetry["renderer"] == "3d"

    neutral, jaw, blink, smile, missing = stills(
        page, [{}, {"bs": {"jawOpen": 1}}, {"bs": {"eyeBlinkLeft": 1}},
               {"bs": {"mouthSmileLeft": 1}}, {"bs": {"browInnerUp": 1}}], 320, 320)  # fmt: skip
    assert (np.abs(neutral - neutral[2, 2]).sum(axis=2) > 60).mean() > 0.1  # a head is drawn
    for image in (jaw, blink, smile):
        assert changed(neutral, image).sum() > 50
    assert changed(neutral, missing).sum() == 0
    # The Left shape moved the viewer's right side of the head.
    _, xs = np.nonzero(changed(neutral, blink))
    assert xs.mean() > 160
    page.close()


def test_a_head_file_that_does_not_load_falls_back_to_2d(
    webgl_browser: Browser, display_url: str, settings: Settings
) -> None:
    (heads_dir(settings) / "broken.glb").write_bytes(b"glTF not really")
    page = webgl_browser.new_page(viewport={"width": 640, "height": 480})
    open_head(page, display_url + "?renderer=3d&head=broken.glb")
    assert page.evaluate("window.robotDisplay.renderer().kind") == "2d"
    assert "3D head unavailable" in page.locator("#renderer-note").inner_text()
    page.close()
