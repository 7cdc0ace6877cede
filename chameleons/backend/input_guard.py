"""Refuse, at the edge and with a sentence, input that no route can store or look up.

Each of these used to reach the database and come back as a 500 (or, on the phone, as an
endless "connection is down" retry, since the phone retries only 5xx):

- a NUL character in any text: PostgreSQL's text types cannot hold it (SQLite can, so the
  two databases would disagree); refused in the address (400), in JSON bodies and in form
  fields (422);
- a whole number too large for the database: SQLite raises ``OverflowError`` from 2**63
  and PostgreSQL "integer out of range" from 2**31, the size of every row id (INTEGER).
  In the address (path segments and query values, where numbers are ids, counts and
  positions) the limit is 2**31 - 1: a path segment beyond it names nothing (404), a
  query value is a 422. In JSON bodies it is 2**63 - 1 (free JSON payloads may carry
  nanosecond times); id fields of bodies carry their own bound (``MAX_ROW_ID``);
- a lone surrogate (``"\\ud800"``) in a JSON string: valid JSON, but not Unicode text that
  UTF-8 (the databases', files') can encode (422);
- ``NaN``/``Infinity`` in JSON bodies: Python's JSON parser accepts them, JSON does not,
  PostgreSQL's JSON columns refuse them, and no measure of this study is one (422); so is
  a number beyond what a float holds (``1e400``), which the parser turns into infinity;
- a JSON body nested deeper than ``MAX_JSON_DEPTH`` (no route takes more than a few
  levels): 50,000 nested lists made the parser raise ``RecursionError`` (422).

A pure ASGI middleware: it buffers only JSON and form bodies (which FastAPI reads whole
anyway) and hands the same bytes on. Multipart bodies pass through (files may hold NULs).
The messages are plain sentences in ``detail``, which the phone shows as they are. On the
participant's routes they are in the participant's language: the phone's script sends its
page's language (the session's) as ``Accept-Language``; ``/join``'s form has the browser's
own, as its page does. This runs before any route, so it reads no session.
"""

from __future__ import annotations

import json
import math
import re
from typing import Any
from urllib.parse import parse_qsl

from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from chameleons.i18n import N_, preferred_language, translations

DB_INT_LIMIT = 2**63  # SQLite INTEGER and PostgreSQL BIGINT hold -2**63 .. 2**63 - 1
MAX_ROW_ID = 2**31 - 1  # PostgreSQL INTEGER: every row id but the events'
_WHOLE_NUMBER = re.compile(r"-?\d+")
_ID_WITH_EXTENSION = re.compile(r"(?<=\d)\.[A-Za-z0-9]{1,8}$")

NUL_IN_ADDRESS = N_("The address contains a NUL character (0x00), which is not allowed.")
NUL_IN_TEXT = N_("Text may not contain a NUL character (0x00). Please remove it and try again.")
NOT_UNICODE = N_(
    "Text must be valid Unicode (it contains a lone surrogate escape such as \\ud800)."
)
NOT_FINITE = N_("Numbers must be finite: NaN and Infinity are not allowed.")
TOO_LARGE_NUMBER = N_("A number in the request is too large (the limit is about 1.8e308).")
MAX_JSON_DEPTH = 64
TOO_DEEP = N_("The request is nested too deeply (the limit is 64 levels).")
TOO_LARGE = N_("A whole number in the request is too large (the limit is 2^63 - 1).")
TOO_LARGE_IN_ADDRESS = N_("A number in the address is too large (the limit is 2147483647).")
NO_SUCH_THING = "Not Found"
PARTICIPANT_PREFIXES = ("/api/phone/", "/p/")
# Query parameters that are text however they look: a phone's device id is 32 random hex
# digits (static/phone/storage.js), which may all be decimal digits, and a display key or
# booth name may be too. Only numbers are range-checked (a device id of 16 digits was
# refused as "too large", seen as a rare 403 on the phone's socket in
# bench/server_bench.py).
TEXT_QUERY_PARAMETERS = frozenset({"device", "key", "booth"})


class _Refused(Exception):  # noqa: N818 (a refusal carrying its message, not a fault)
    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


def _too_large(text: str, limit: int = DB_INT_LIMIT) -> bool:
    return bool(_WHOLE_NUMBER.fullmatch(text)) and abs(int(text)) >= limit


def _parse_int(text: str) -> int:
    if _too_large(text):
        raise _Refused(TOO_LARGE)
    return int(text)


def _reject_constant(name: str) -> float:
    raise _Refused(NOT_FINITE)


def _parse_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):  # 1e400: beyond a double, not a number JSON allows
        raise _Refused(TOO_LARGE_NUMBER)
    return value


def _check_strings(value: Any) -> None:
    """Walk a decoded JSON value (keys too) for NUL characters, lone surrogates and
    nesting deeper than ``MAX_JSON_DEPTH`` (iteratively: no recursion to run out of)."""
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, str):
            if "\x00" in item:
                raise _Refused(NUL_IN_TEXT)
            if not item.isascii():
                try:
                    item.encode("utf-8")
                except UnicodeEncodeError:
                    raise _Refused(NOT_UNICODE) from None
        elif isinstance(item, dict | list):
            if depth > MAX_JSON_DEPTH:
                raise _Refused(TOO_DEEP)
            values = [*item.keys(), *item.values()] if isinstance(item, dict) else item
            stack.extend((inner, depth + 1) for inner in values)


def check_json(body: bytes) -> None:
    try:
        decoded = json.loads(
            body, parse_constant=_reject_constant, parse_int=_parse_int, parse_float=_parse_float
        )
    except RecursionError:  # nested beyond the parser's own recursion limit
        raise _Refused(TOO_DEEP) from None
    except ValueError:
        return  # malformed JSON: FastAPI answers it with its own 422
    _check_strings(decoded)


def check_form(body: bytes) -> None:
    try:
        fields = parse_qsl(body.decode("latin-1"), keep_blank_values=True)
    except ValueError:
        return
    for name, value in fields:
        if "\x00" in name or "\x00" in value:
            raise _Refused(NUL_IN_TEXT)


def check_address(scope: Scope) -> tuple[int, str] | None:
    if "\x00" in scope["path"]:
        return 400, NUL_IN_ADDRESS
    # A segment may be an id with a file extension (/pi/sessions/1/instruments/7.svg).
    segments = (_ID_WITH_EXTENSION.sub("", segment) for segment in scope["path"].split("/"))
    if any(_too_large(segment, MAX_ROW_ID + 1) for segment in segments):
        return 404, NO_SUCH_THING
    query = scope.get("query_string", b"").decode("latin-1")
    for name, value in parse_qsl(query, keep_blank_values=True):
        if "\x00" in name or "\x00" in value:
            return 400, NUL_IN_ADDRESS
        if name not in TEXT_QUERY_PARAMETERS and _too_large(value.strip(), MAX_ROW_ID + 1):
            return 422, TOO_LARGE_IN_ADDRESS
    return None


def _body_checker(scope: Scope) -> Any:
    content_type = ""
    for name, value in scope.get("headers", ()):
        if name == b"content-type":
            content_type = value.decode("latin-1").split(";", 1)[0].strip().lower()
    if content_type == "application/json" or content_type.endswith("+json"):
        return check_json
    if content_type == "application/x-www-form-urlencoded":
        return check_form
    return None


def in_language(scope: Scope, message: str) -> str:
    """``message`` in the participant's language on their routes; English elsewhere."""
    path = scope["path"]
    if not (path.startswith(PARTICIPANT_PREFIXES) or path == "/join"):
        return message
    header = next(
        (v.decode("latin-1") for n, v in scope.get("headers", ()) if n == b"accept-language"), ""
    )
    return translations(preferred_language(header)).gettext(message)


class InputGuardMiddleware:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        refused = check_address(scope)
        if refused is not None:
            if scope["type"] == "websocket":
                await send({"type": "websocket.close", "code": 1008})  # before accept: a 403
            else:
                detail = in_language(scope, refused[1])
                await JSONResponse({"detail": detail}, refused[0])(scope, receive, send)
            return
        checker = _body_checker(scope) if scope["type"] == "http" else None
        if checker is None:
            await self.app(scope, receive, send)
            return
        messages, body = await _read_body(receive)
        try:
            checker(body)
        except _Refused as refusal:
            detail = in_language(scope, refusal.message)
            await JSONResponse({"detail": detail}, 422)(scope, receive, send)
            return
        await self.app(scope, _replay(messages, receive), send)


async def _read_body(receive: Receive) -> tuple[list[Message], bytes]:
    messages: list[Message] = []
    chunks: list[bytes] = []
    while True:
        message = await receive()
        messages.append(message)
        if message["type"] != "http.request":
            break
        chunks.append(message.get("body", b""))
        if not message.get("more_body", False):
            break
    return messages, b"".join(chunks)


def _replay(messages: list[Message], receive: Receive) -> Receive:
    pending = list(messages)

    async def replayed() -> Message:
        if pending:
            return pending.pop(0)
        return await receive()

    return replayed
