"""Unguessable per-booth display links without a schema change: HMACs of the booth id.

The display token is ``HMAC-SHA256(secret_key, "display:" + booth)``; media links use
``"media:" + actor``. Changing ``CHAMELEONS_SECRET_KEY`` invalidates every link; the PI
rotates or retires one booth's link on the display page (``links.py``).
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import re
import secrets
import threading
from typing import Final

from fastapi import FastAPI

from chameleons.settings import Settings

BOOTH_PATTERN: Final = r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$"
_BOOTH = re.compile(BOOTH_PATTERN)
_TOKEN_BYTES = 24
_KEY_LOCK = threading.Lock()


def is_valid_booth(booth: str) -> bool:
    return bool(_BOOTH.match(booth))


def signing_key(app: FastAPI) -> bytes:
    """The secret key; a demo run without one gets a random key for this process only."""
    settings: Settings = app.state.settings
    secret = settings.secret_key.get_secret_value()
    if secret:
        return secret.encode()
    with _KEY_LOCK:
        key = getattr(app.state, "display_ephemeral_key", None)
        if key is None:
            key = secrets.token_bytes(32)
            app.state.display_ephemeral_key = key
    assert isinstance(key, bytes)
    return key


def _sign(key: bytes, purpose: str, subject: str) -> str:
    digest = hmac.new(key, f"{purpose}:{subject}".encode(), hashlib.sha256).digest()
    return base64.urlsafe_b64encode(digest[:_TOKEN_BYTES]).decode().rstrip("=")


def display_token(key: bytes, booth: str, generation: int = 0) -> str:
    """Generation 0 is the booth's first link; the PI's rotations count up (``links.py``)."""
    return _sign(key, "display", booth if generation == 0 else f"{booth}#{generation}")


def media_token(key: bytes, actor: str) -> str:
    return _sign(key, "media", actor)


def check_token(expected: str, given: str | None) -> bool:
    return given is not None and hmac.compare_digest(expected.encode(), given.encode())


def display_path(key: bytes, booth: str, generation: int = 0) -> str:
    """The booth screen's link (relative to the server's public URL)."""
    return f"/display/{booth}/{display_token(key, booth, generation)}"


def capture_token(key: bytes, booth: str, generation: int = 0) -> str:
    """The capture page's key: the display link's generation, another purpose (a display
    link opens no camera, a capture link shows no robot)."""
    return _sign(key, "capture", booth if generation == 0 else f"{booth}#{generation}")


def capture_path(key: bytes, booth: str, generation: int = 0) -> str:
    """The booth's webcam capture page (``chameleons.backend.capture``)."""
    return f"/capture/{booth}/{capture_token(key, booth, generation)}"
