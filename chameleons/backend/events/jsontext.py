"""The JSON text of live messages: WebSocket frames to consoles, phones and robot displays,
and NOTIFY payloads between server processes.

orjson writes a console's state (about 9 kB) in a tenth of the standard library's time
(16 against 167 microseconds on the bench machine, docs/performance.md), and these are
written on the event loop that also delivers every other live update. What orjson refuses
(an integer beyond 64 bits) is written by the standard library as before. Two differences
in what it writes, both valid JSON that browsers read the same: text outside ASCII is kept
as UTF-8 instead of ``\\u`` escapes, and a float NaN or infinity becomes ``null`` (the
standard library's ``NaN`` is not JSON, and a browser's ``JSON.parse`` refuses it).
"""

from __future__ import annotations

import json
from typing import Any

import orjson

_OPTIONS = orjson.OPT_NON_STR_KEYS  # int keys as strings, as the standard library does


def dumps(value: Any) -> str:
    """Compact JSON text of ``value``."""
    return dump_bytes(value).decode()


def dump_bytes(value: Any) -> bytes:
    """Compact JSON of ``value`` as UTF-8 bytes."""
    try:
        return orjson.dumps(value, option=_OPTIONS)
    except orjson.JSONEncodeError:
        return json.dumps(value, separators=(",", ":"), ensure_ascii=False).encode()
