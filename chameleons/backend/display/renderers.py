"""Which face a robot display paints (2D cartoon or 3D head) and a lab's own 3D heads.

The renderer is chosen, first to last: the study's condition (``renderer:`` in the study
file, sent with ``set_face``), the display link's ``?renderer=2d|3d``, the booth's default
(``display_link.renderer``, set by the PI on ``/display``), ``CHAMELEONS_DISPLAY_RENDERER``.
The page learns the last three from this module; the condition's arrives over the socket.

A lab's own head is a GLB (or VRM, which is GLB) whose blendshapes use ARKit's names
("perfect sync"), dropped into ``<data dir>/heads/``; ``?head=<file>`` on the link or the
booth's default picks it, and the page reports which of the 52 shapes it lacks.
"""

from __future__ import annotations

import base64
import hashlib
import json
import re
from pathlib import Path
from typing import Final

from chameleons.settings import Settings

RENDERERS: Final = ("2d", "3d")
HEAD_SUFFIXES: Final = (".glb", ".vrm")
_HEAD_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,100}$")
HEADS_DIR_NAME: Final = "heads"


def choose(query: str | None, booth_default: str | None, settings: Settings) -> tuple[str, str]:
    """(renderer, where it came from: "link" | "booth" | "setting")."""
    if query in RENDERERS:
        return str(query), "link"
    if booth_default in RENDERERS:
        return str(booth_default), "booth"
    return settings.display_renderer, "setting"


def heads_dir(settings: Settings) -> Path:
    return settings.data_dir / HEADS_DIR_NAME


def is_head_name(name: str) -> bool:
    return bool(_HEAD_NAME.match(name)) and name.lower().endswith(HEAD_SUFFIXES)


def available_heads(settings: Settings) -> list[str]:
    """The head files in the heads folder, by name."""
    folder = heads_dir(settings)
    if not folder.is_dir():
        return []
    return sorted(p.name for p in folder.iterdir() if p.is_file() and is_head_name(p.name))


def head_file(settings: Settings, name: str) -> Path | None:
    """The head file of that name, if it exists (never a path outside the folder)."""
    if not is_head_name(name):
        return None
    path = heads_dir(settings) / name
    return path if path.is_file() else None


def import_map(static_url: str) -> tuple[str, str]:
    """The page's import map (``three`` and its addons, served from this server) and the
    CSP source that lets exactly this inline map run (``'sha256-...'``)."""
    base = static_url.rstrip("/") + "/vendor/three/"
    text = json.dumps(
        {
            "imports": {
                "three": base + "build/three.module.min.js",
                "three/addons/": base + "addons/",
            }
        },
        separators=(",", ":"),
    )
    digest = base64.b64encode(hashlib.sha256(text.encode()).digest()).decode()
    return text, f"'sha256-{digest}'"
