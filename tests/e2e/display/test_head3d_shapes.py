"""All 52 ARKit shapes of the 3D head in Chromium (software WebGL): each changes pixels, and
only in the region Apple's definition names, on the correct side; every *Left shape is the
mirror image of its *Right twin. One page load renders all of them through the page's still
renderer (``robotDisplay.head3d().stills``)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from playwright.sync_api import Browser, Page

from chameleons.worker.frames import BLENDSHAPE_NAMES
from tests.support.head3d import centroid, changed, open_head, screen_points, stills

pytestmark = pytest.mark.browser
WIDTH, HEIGHT = 360, 450
MIN_CHANGED = 20  # pixels: a shape at 1.0 that moves fewer is invisible at this size
INSIDE = 0.95  # share of a shape's changed pixels that must lie in its region


def region_of(name: str) -> tuple[str, float]:
    """(the landmark point the shape's region is centred on, radius in eye distances)."""
    side = "L" if name.endswith("Left") else "R" if name.endswith("Right") else ""
    if name.startswith("eye"):
        return "eye" + side, 0.6
    if name.startswith("jaw"):
        return "jaw", 1.35
    if name == "cheekPuff":
        return "mouth", 1.45
    if name.startswith("mouth") or name == "tongueOut":
        return "mouth", 1.0
    if name == "browInnerUp":
        return "browMid", 0.8
    if name.startswith("brow"):
        return "brow" + side, 0.65
    if name.startswith("cheekSquint"):
        return "cheek" + side, 0.75
    if name.startswith("noseSneer"):
        return "nose" + side, 0.6
    raise AssertionError(f"no region for {name}")


Renders = tuple[dict[str, np.ndarray], dict[str, tuple[float, float]]]


@pytest.fixture(scope="module")
def renders(webgl_browser: Browser, display_url_module: str) -> Renders:
    page: Page = webgl_browser.new_page(viewport={"width": 640, "height": 480})
    open_head(page, display_url_module + "?renderer=3d")
    assert page.evaluate("window.robotDisplay.renderer().kind") == "3d"
    requests: list[dict[str, Any]] = [{}, *({"bs": {name: 1.0}} for name in BLENDSHAPE_NAMES)]
    images = stills(page, requests, WIDTH, HEIGHT)
    points = screen_points(page, WIDTH, HEIGHT)
    page.close()
    return dict(zip(["neutral", *BLENDSHAPE_NAMES], images, strict=True)), points


def test_the_head_renders_all_52_shapes(renders: Renders) -> None:
    images, _ = renders
    assert len(images) == 53
    neutral = images["neutral"]
    # A head on the background, not an empty canvas.
    assert (np.abs(neutral - neutral[2, 2]).sum(axis=2) > 60).mean() > 0.15


@pytest.mark.parametrize("name", BLENDSHAPE_NAMES)
def test_each_shape_changes_pixels_in_its_region_only(name: str, renders: Renders) -> None:
    images, points = renders
    mask = changed(images["neutral"], images[name])
    count = int(mask.sum())
    assert count >= MIN_CHANGED, f"{name} changed only {count} pixels"
    eye_distance = float(np.hypot(points["eyeL"][0] - points["eyeR"][0],
                                  points["eyeL"][1] - points["eyeR"][1]))  # fmt: skip
    where, radius = region_of(name)
    if where == "jaw":
        (mx, my), (cx, cy) = points["mouth"], points["chin"]
        centre = ((mx + cx) / 2, (my + cy) / 2)
    else:
        centre = points[where]
    ys, xs = np.nonzero(mask)
    inside = np.hypot(xs - centre[0], ys - centre[1]) <= radius * eye_distance
    assert inside.mean() >= INSIDE, (
        f"{name}: {inside.mean():.1%} of {count} changed pixels within {radius} eye distances "
        f"of {where}"
    )
    middle = points["nose"][0]
    x, _ = centroid(mask)
    # ARKit's Left is the face's own left, which the viewer sees on the right.
    if name.endswith("Left"):
        assert x > middle, f"{name} changed the viewer's left side (x {x:.0f} < {middle:.0f})"
    elif name.endswith("Right"):
        assert x < middle, f"{name} changed the viewer's right side (x {x:.0f} > {middle:.0f})"
    else:
        assert abs(x - middle) < 0.25 * eye_distance, f"{name} is lopsided (x {x:.0f})"


PAIRS = [n for n in BLENDSHAPE_NAMES if n.endswith("Left")]


@pytest.mark.parametrize("left", PAIRS)
def test_left_mirrors_right(left: str, renders: Renders) -> None:
    images, points = renders
    right = left[: -len("Left")] + "Right"
    neutral = images["neutral"]
    a = changed(neutral, images[left])
    b = changed(neutral, images[right])
    # Mirror about the face's own midline (the nose tip's column).
    axis = points["nose"][0]
    ys, xs = np.nonzero(a)
    mirrored = np.zeros_like(a)
    mx = np.round(2 * axis - xs).astype(int)
    keep = (mx >= 0) & (mx < a.shape[1])
    mirrored[ys[keep], mx[keep]] = True
    grown = _dilate(b, 2)
    overlap = (mirrored & grown).sum() / max(1, mirrored.sum())
    assert overlap > 0.8, f"{left} mirrored covers only {overlap:.0%} of {right}'s change"
    assert abs(int(a.sum()) - int(b.sum())) <= 0.2 * max(a.sum(), b.sum()) + 10


def _dilate(mask: np.ndarray, steps: int) -> np.ndarray:
    out = mask.copy()
    for _ in range(steps):
        grown = out.copy()
        grown[1:] |= out[:-1]
        grown[:-1] |= out[1:]
        grown[:, 1:] |= out[:, :-1]
        grown[:, :-1] |= out[:, 1:]
        out = grown
    return out
