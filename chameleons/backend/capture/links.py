"""The capture page's keyed link: ``HMAC(secret_key, "capture:<booth>[#generation]")``.

It follows the booth's display link (:mod:`chameleons.backend.display.links`): rotating
the display link rotates this one, retiring the booth retires both.
"""

from __future__ import annotations

from fastapi import FastAPI, Request
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.db import session_scope
from chameleons.backend.display import links as display_links
from chameleons.backend.display.tokens import capture_path, capture_token, check_token, signing_key


def token_works(db: DbSession, app: FastAPI, booth: str, token: str | None) -> bool:
    current = display_links.generation(db, booth)
    return current is not None and check_token(
        capture_token(signing_key(app), booth, current), token
    )


def current_capture_path(app: FastAPI, booth: str) -> str | None:
    """The booth's working capture path; ``None`` when the booth is retired."""
    with session_scope(app.state.sessionmaker) as db:
        current = display_links.generation(db, booth)
    return None if current is None else capture_path(signing_key(app), booth, current)


def capture_url(app: FastAPI, booth: str, base: str | None = None) -> str | None:
    """The full link to print, show and scan: ``base`` (default: the server's public URL)
    + the path."""
    path = current_capture_path(app, booth)
    base = base if base is not None else app.state.settings.effective_public_url
    return None if path is None else base + path


def request_base(request: Request) -> str:
    """The configured public URL, else the one this page was asked for (a QR code shown on
    a page must hold an address the page's own computer reached)."""
    configured = request.app.state.settings.public_url
    return str(configured or request.base_url).rstrip("/")
