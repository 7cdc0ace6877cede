"""The 3D robot head's atlas for reviewers: the four study faces at rest, then each of the
52 ARKit shapes at 1.0 on face-1, rendered by the display page itself (software WebGL in
headless Chromium) through its still renderer.

    .venv/bin/python scripts/make_head_atlas.py [--out docs/head-atlas.png] [--face face-1]

It starts the app on a temporary SQLite database in this process (loopback, a free port).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw
from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from chameleons.worker.frames import BLENDSHAPE_NAMES  # noqa: E402
from tests.support.head3d import display_server, launch_webgl, open_head, stills  # noqa: E402

TILE = 200  # px of each cell (the render is cropped to the face)
COLUMNS = 8
LABEL = 16
FACES = ("face-1", "face-2", "face-3", "face-4")


def crop(image: np.ndarray) -> Image.Image:
    """The face out of a 320 x 320 render (the head sits in the upper middle)."""
    return Image.fromarray(image.astype("uint8")).crop((60, 20, 260, 220)).resize((TILE, TILE))


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "head-atlas.png")
    parser.add_argument("--face", default="face-1", choices=FACES)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp, display_server(Path(tmp)) as (url, _app), \
            sync_playwright() as playwright:  # fmt: skip
        browser = launch_webgl(playwright)
        page = browser.new_page(viewport={"width": 640, "height": 480})
        open_head(page, url + "?renderer=3d")
        faces = [stills(page, [{}], 320, 320, face)[0] for face in FACES]
        shapes = stills(page, [{"bs": {n: 1.0}} for n in BLENDSHAPE_NAMES], 320, 320, args.face)
        browser.close()
    cells = [(f"{face} at rest", image) for face, image in zip(FACES, faces, strict=True)]
    cells += list(zip(BLENDSHAPE_NAMES, shapes, strict=True))
    rows = 1 + -(-len(BLENDSHAPE_NAMES) // COLUMNS)
    atlas = Image.new("RGB", (COLUMNS * TILE, rows * (TILE + LABEL)), "white")
    draw = ImageDraw.Draw(atlas)
    for k, (name, image) in enumerate(cells):
        slot = k if k < len(FACES) else COLUMNS + k - len(FACES)
        x, y = (slot % COLUMNS) * TILE, (slot // COLUMNS) * (TILE + LABEL)
        atlas.paste(crop(image), (x, y + LABEL))
        draw.text((x + 4, y + 2), name, fill="black")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atlas.save(args.out, optimize=True)
    print(f"wrote {args.out} ({args.out.stat().st_size // 1024} KB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
