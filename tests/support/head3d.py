"""Helpers for the robot display's 3D head in Chromium: a WebGL-capable browser, the page's
still renderer (``robotDisplay.head3d().stills``), pixel differences, and a small GLB head
with ARKit-named morph targets written byte by byte (glTF 2.0 binary container).

Used by the browser tests (tests/e2e/display/test_head3d_*.py), the atlas script
(scripts/make_head_atlas.py) and the display benchmark (bench/display_bench.py).
"""

from __future__ import annotations

import base64
import io
import json
import math
import secrets
import struct
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image
from playwright.sync_api import Browser, Page, Playwright

from tests.support.browser import CHROMIUM_ARGS, chromium_path, wait_for_js

# Software WebGL (SwiftShader through ANGLE), as on a booth PC without a GPU driver.
WEBGL_ARGS = [a for a in CHROMIUM_ARGS if a != "--disable-gpu"] + [
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
]
NO_WEBGL_ARGS = [*CHROMIUM_ARGS, "--disable-webgl", "--disable-3d-apis"]
HEAD_READY = (
    "window.robotDisplay && window.robotDisplay.connected() && window.robotDisplay.renderer().ready"
)
# Landmarks whose resting screen positions say where each shape may change pixels.
POINTS = {
    "eyeL": 386, "eyeR": 159, "browL": 334, "browR": 105, "browMid": 9, "mouth": 13,
    "cornerL": 291, "cornerR": 61, "chin": 152, "cheekL": 330, "cheekR": 101,
    "noseL": 437, "noseR": 217, "nose": 1, "cheekPuffL": 427, "cheekPuffR": 207,
}  # fmt: skip


def launch_webgl(playwright: Playwright, webgl: bool = True) -> Browser:
    return playwright.chromium.launch(
        executable_path=chromium_path(), headless=True, args=WEBGL_ARGS if webgl else NO_WEBGL_ARGS
    )


def open_head(page: Page, url: str) -> None:
    """Open a display link and wait until its (3D or fallback) face is ready."""
    page.goto(url)
    wait_for_js(page, HEAD_READY, timeout=90_000)


def decode(data_url: str) -> np.ndarray:
    png = base64.b64decode(data_url.split(",", 1)[1])
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def stills(
    page: Page, requests: Sequence[dict[str, Any]], width: int, height: int, face: str = "face-1"
) -> list[np.ndarray]:
    """Render each ``{"bs": {name: value}, "head": [...]}`` in one page call; RGB arrays."""
    urls: list[str] = page.evaluate(
        "([r, w, h, f]) => window.robotDisplay.head3d().stills(r, w, h, f)",
        [list(requests), width, height, face],
    )
    return [decode(u) for u in urls]


def screen_points(page: Page, width: int, height: int) -> dict[str, tuple[float, float]]:
    """The resting face's landmark positions (px) at width x height."""
    points: dict[str, list[float]] = page.evaluate(
        "([ids, w, h]) => window.robotDisplay.head3d().screenPoints(ids, w, h)",
        [POINTS, width, height],
    )
    return {name: (xy[0], xy[1]) for name, xy in points.items()}


def changed(a: np.ndarray, b: np.ndarray, threshold: int = 30) -> np.ndarray:
    """Pixels whose RGB differs by more than ``threshold`` (summed over channels)."""
    diff: np.ndarray = np.abs(a - b).sum(axis=2) > threshold
    return diff


def centroid(mask: np.ndarray) -> tuple[float, float]:
    ys, xs = np.nonzero(mask)
    return float(xs.mean()), float(ys.mean())


# ---- a GLB head --------------------------------------------------------------------------


def sphere_head(
    targets: dict[str, tuple[tuple[float, float, float], tuple[float, float, float], float]],
    rings: int = 24,
    segments: int = 32,
) -> bytes:
    """A GLB with one sphere mesh (radius 10, facing +z) and one morph target per entry:
    ``name -> (centre, displacement, radius)``, a Gaussian bump of the surface."""
    positions, normals = [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments + 1):
            phi = 2 * math.pi * j / segments
            n = (math.sin(theta) * math.sin(phi), math.cos(theta), math.sin(theta) * math.cos(phi))
            normals.append(n)
            positions.append(tuple(10 * c for c in n))
    indices = []
    for i in range(rings):
        for j in range(segments):
            a, b = i * (segments + 1) + j, (i + 1) * (segments + 1) + j
            indices += [a, b, a + 1, b, b + 1, a + 1]
    pos = np.array(positions, dtype="<f4")
    morphs = []
    for centre, move, radius in targets.values():
        d2 = ((pos - np.array(centre, dtype="<f4")) ** 2).sum(axis=1)
        weight = np.exp(-d2 / radius**2)[:, None]
        morphs.append((weight * np.array(move, dtype="<f4")).astype("<f4"))
    return _glb(pos, np.array(normals, dtype="<f4"), np.array(indices, dtype="<u2"), morphs,
                list(targets))  # fmt: skip


def _glb(
    pos: np.ndarray, normals: np.ndarray, index: np.ndarray, morphs: list[np.ndarray],
    names: list[str],
) -> bytes:  # fmt: skip
    chunks = [pos.tobytes(), normals.tobytes(), index.tobytes(), *(m.tobytes() for m in morphs)]
    views, offset, blob = [], 0, b""
    for chunk in chunks:
        padded = chunk + b"\0" * (-len(chunk) % 4)
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(chunk)})
        offset += len(padded)
        blob += padded
    count = len(pos)

    def vec3(view: int, data: np.ndarray) -> dict[str, Any]:
        return {"bufferView": view, "componentType": 5126, "count": count, "type": "VEC3",
                "min": data.min(axis=0).tolist(), "max": data.max(axis=0).tolist()}  # fmt: skip

    accessors = [
        vec3(0, pos),
        vec3(1, normals),
        {"bufferView": 2, "componentType": 5123, "count": len(index), "type": "SCALAR"},
    ]
    accessors += [vec3(3 + k, m) for k, m in enumerate(morphs)]  # fmt: skip
    targets = [{"POSITION": 3 + k} for k in range(len(morphs))]
    document = {
        "asset": {"version": "2.0", "generator": "chameleons tests"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "face"}],
        "meshes": [{"name": "face", "extras": {"targetNames": names}, "weights": [0] * len(names),
                    "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2,
                                    "material": 0, "targets": targets}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.85, 0.7, 0.6, 1],
                                                "metallicFactor": 0, "roughnessFactor": 1}}],
        "accessors": accessors, "bufferViews": views, "buffers": [{"byteLength": len(blob)}],
    }  # fmt: skip
    text = json.dumps(document).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text
    body += struct.pack("<II", len(blob), 0x004E4942) + blob
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


@contextmanager
def display_server(folder: Path, **settings: Any) -> Iterator[tuple[str, Any]]:
    """A migrated SQLite database, the app and a live server in this process; yields the
    display link of booth-1 and the app (for scripts and benchmarks that need the page)."""
    from chameleons.backend.app import create_app
    from chameleons.backend.display.tokens import display_path, signing_key
    from chameleons.backend.migrate import upgrade
    from chameleons.settings import Settings
    from tests.support.live_server import LiveServer

    url = f"sqlite:///{folder / 'display.sqlite3'}"
    upgrade(url)
    key = secrets.token_urlsafe(32)
    config = Settings(database_url=url, data_dir=folder / "data", secret_key=key,
                      bridge_enabled=False, _env_file=None, **settings)  # fmt: skip
    app = create_app(config)
    server = LiveServer(app).start()
    try:
        yield server.url + display_path(signing_key(app), "booth-1"), app
    finally:
        server.stop()
        app.state.engine.dispose()
