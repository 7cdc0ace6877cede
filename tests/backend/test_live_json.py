"""The JSON text of live messages (``events.jsontext``): what the standard library wrote,
read back the same, written by orjson; what orjson refuses still written."""

from __future__ import annotations

import json
import math

from chameleons.backend.events import jsontext, pg_fanout
from chameleons.backend.events.hub import RESYNC, LiveHub

CONSOLE_LIKE = {
    "type": "console",
    "session": {"id": 7, "booth": "booth-1", "language": "de", "phones": [], "flags": None},
    "events": [
        {
            "id": 3,
            "kind": "phone.ranking",
            "payload": {"ranking": [4, 1, 2]},
            "client_id": "c-1",
            "note": "Überlebensaufgabe ✓",
            "score": 0.1,
        }
    ],
    "prompt_position": 1,
    "counts": {1: 2, 2: 0},  # int keys, as the standard library writes them
}


def test_a_message_reads_back_as_the_standard_librarys_text_does() -> None:
    written = jsontext.dumps(CONSOLE_LIKE)
    assert json.loads(written) == json.loads(json.dumps(CONSOLE_LIKE))
    assert ": " not in written  # compact, as before
    assert ", " not in written


def test_text_outside_ascii_stays_utf8() -> None:
    written = jsontext.dumps({"note": "Überlebensaufgabe ✓"})
    assert written == '{"note":"Überlebensaufgabe ✓"}'  # the standard library escapes: \u00dc
    assert jsontext.dump_bytes({"note": "Ü"}) == '{"note":"Ü"}'.encode()


def test_nan_becomes_null_which_a_browser_can_parse() -> None:
    """orjson's rule (the standard library writes NaN): this is orjson writing."""
    assert json.loads(jsontext.dumps({"x": math.nan, "y": math.inf})) == {"x": None, "y": None}


def test_what_orjson_refuses_is_still_written() -> None:
    huge = 2**70  # beyond orjson's 64-bit integers
    assert json.loads(jsontext.dumps({"n": huge})) == {"n": huge}


def test_a_notify_payload_is_measured_in_utf8_bytes() -> None:
    """PostgreSQL counts a payload's bytes: a message of 3,000 two-byte letters (6,000 bytes
    of UTF-8 plus the envelope) fits, one of 4,000 (over 7,900 bytes) goes as a resync."""
    fits = pg_fanout.encode("o", "session:1", {"note": "Ü" * 3000})
    assert json.loads(fits)["m"] == {"note": "Ü" * 3000}
    too_big = pg_fanout.encode("o", "session:1", {"note": "Ü" * 4000})
    assert len(("Ü" * 4000).encode()) > pg_fanout.MAX_PAYLOAD
    assert json.loads(too_big)["m"] == RESYNC


def test_a_process_skips_its_own_notifications_and_reads_the_others() -> None:
    """PostgreSQL delivers a process's NOTIFYs to its own LISTEN too: those are recognised by
    their first bytes, so only another process's message reaches the hub."""
    delivered: list[tuple[str, dict[str, object]]] = []

    class Hub(LiveHub):
        def deliver(self, channel: str, message: dict[str, object]) -> None:
            delivered.append((channel, message))

    ours = pg_fanout.PgFanout(Hub(), "postgresql://unused")
    other = pg_fanout.PgFanout(LiveHub(), "postgresql://unused")
    ours._receive(pg_fanout.encode(ours.origin, "session:1", {"type": "event", "n": 1}))
    ours._receive(pg_fanout.encode(other.origin, "session:1", {"type": "event", "n": 2}))
    ours._receive("{not json")  # logged as unreadable and dropped, not raised
    assert delivered == [("session:1", {"type": "event", "n": 2})]
