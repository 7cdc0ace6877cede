"""Keep credentials out of the server's logs: participant phone tokens, display links,
``?token=`` and media ``?key=`` are replaced before uvicorn's access and WebSocket lines
are written (they are in the URL paths those lines quote)."""

from __future__ import annotations

import logging
import re

_PATTERNS = (
    # /p/<token>, /ws/p/<token>, /api/phone/<token>/...: the participant's link
    (re.compile(r"(/(?:ws/)?p/|/api/phone/)[^/?#\s\"]+"), r"\1<token>"),
    # /display/<booth>/<token>: the booth screen's link
    (re.compile(r"(/display/[^/?#\s\"]+/)[^/?#\s\"]+"), r"\1<token>"),
    # /capture/<booth>/<key>: the booth's webcam capture page
    (re.compile(r"(/capture/[^/?#\s\"]+/)[^/?#\s\"]+"), r"\1<token>"),
    # /video/<booth>/<key>: the booth's participant-video page (its API under /api/video/
    # takes the key in a header, never in the address)
    (re.compile(r"((?<!/api)/video/[^/?#\s\"]+/)[^/?#\s\"]+"), r"\1<token>"),
    (re.compile(r"([?&](?:token|key)=)[^&#\s\"]+"), r"\1<redacted>"),
)
LOGGERS = ("uvicorn.access", "uvicorn.error")


def redact(text: str) -> str:
    for pattern, replacement in _PATTERNS:
        text = pattern.sub(replacement, text)
    return text


class RedactSecrets(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        if isinstance(record.args, tuple):
            record.args = tuple(redact(a) if isinstance(a, str) else a for a in record.args)
        elif isinstance(record.msg, str) and not record.args:
            record.msg = redact(record.msg)
        return True


def install() -> None:
    """Add the filter to uvicorn's loggers (once per process)."""
    for name in LOGGERS:
        logger = logging.getLogger(name)
        if not any(isinstance(f, RedactSecrets) for f in logger.filters):
            logger.addFilter(RedactSecrets())
