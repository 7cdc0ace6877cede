"""Participant tokens, display links and media keys never reach the access log."""

from __future__ import annotations

import logging

import pytest
from fastapi import FastAPI

from chameleons.backend.logredact import LOGGERS, RedactSecrets, redact


@pytest.mark.parametrize(
    ("line", "secret"),
    [
        ("GET /p/Zx9_secretToken HTTP/1.1", "Zx9_secretToken"),
        ("/ws/p/Zx9_secretToken", "Zx9_secretToken"),
        ("POST /api/phone/Zx9_secretToken/ranking", "Zx9_secretToken"),
        ("GET /display/booth-1/AbC_displayKey", "AbC_displayKey"),
        ("/ws/display/booth-1?token=AbC_displayKey", "AbC_displayKey"),
        ("/media/prompts/m1/audio/a.wav?key=MediaKey123&x=1", "MediaKey123"),
        ("GET /video/booth-1/VidKey_456 HTTP/1.1", "VidKey_456"),
    ],
)
def test_secrets_in_paths_are_redacted(line: str, secret: str) -> None:
    cleaned = redact(line)
    assert secret not in cleaned
    assert "<token>" in cleaned or "<redacted>" in cleaned


def test_uvicorn_access_lines_are_filtered(app: FastAPI) -> None:
    """uvicorn's access line: '%s - "%s %s HTTP/%s" %d' with the path as an argument."""
    logger = logging.getLogger("uvicorn.access")
    assert any(
        isinstance(f, RedactSecrets) for name in LOGGERS for f in logging.getLogger(name).filters
    )
    record = logger.makeRecord(
        "uvicorn.access", logging.INFO, __file__, 1, '%s - "%s %s HTTP/%s" %d',
        ("127.0.0.1:5000", "GET", "/p/Zx9_secretToken", "1.1", 200), None,
    )  # fmt: skip
    assert all(f.filter(record) for f in logger.filters if isinstance(f, RedactSecrets))
    assert "Zx9_secretToken" not in record.getMessage()
    assert "/p/<token>" in record.getMessage()


def test_the_video_api_paths_stay_readable() -> None:
    """The recording page's API carries its key in a header: its paths are kept as they are."""
    line = "POST /api/video/booth-1/videos/3/chunks/7 HTTP/1.1"
    assert redact(line) == line
