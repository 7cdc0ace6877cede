"""In Chromium, without a worker: the server sends the console's health once while nothing
changes (issue 34), and the strip still counts how long the worker has been failing,
second by second, without a "no word from the server" alarm."""

from __future__ import annotations

import json
import re
from itertools import pairwise

import pytest
from playwright.sync_api import WebSocket, expect

from tests.e2e.wizard.conftest import Console

pytestmark = pytest.mark.browser
QUIET_S = 10  # longer than the strip's old 3.5 s silence alarm


def test_the_strip_counts_on_between_health_messages(console: Console) -> None:
    page = console.page
    healths: list[str] = []
    # Each connection's own messages: a connection gets the health once when it opens, so a
    # console that reconnects on a busy machine has a second, identical first message.
    by_socket: dict[int, list[str]] = {}

    def watch(socket: WebSocket) -> None:
        mine = by_socket.setdefault(len(by_socket), [])

        def note(payload: str | bytes) -> None:
            text = payload if isinstance(payload, str) else payload.decode()
            if text.replace(" ", "").startswith('{"type":"health"'):
                healths.append(text)
                mine.append(text)

        socket.on("framereceived", note)

    page.on("websocket", watch)
    page.reload()
    since = page.locator("#health .chip[data-check='worker'] .since")
    expect(since).to_have_text(re.compile(r"\d"))
    for _ in range(3):  # it counts on by itself, with no new health message
        shown = since.text_content()
        expect(since).not_to_have_text(shown or "")
    # Until the strip says the worker has failed for QUIET_S s: a silence after which the
    # old alarm (3.5 s without a health message) had long fired.
    page.wait_for_function(
        """([selector, quiet]) => {
          const text = document.querySelector(selector)?.textContent || "";
          const found = text.match(/(\\d+) s/);
          return Boolean(found) && Number(found[1]) >= quiet;
        }""",
        arg=["#health .chip[data-check='worker'] .since", QUIET_S],
        timeout=60_000,
    )
    expect(page.locator("#health")).not_to_contain_text("No word from the server")
    # Sent on a change only: far fewer than one a second, and no message repeats the one
    # before it but for the times that count on (on a busy machine a check that finishes
    # late, such as espeak-ng's, is a real change and is sent).
    assert 1 <= len(healths) <= 3, healths
    for messages in by_socket.values():
        states = [_without_times(h) for h in messages]
        assert all(a != b for a, b in pairwise(states)), states


def _without_times(message: str) -> dict[str, object]:
    body = json.loads(message)
    body.pop("speaking_age_s", None)
    for check in body.get("checks", []):
        check.pop("failing_for", None)
    return dict(body)
