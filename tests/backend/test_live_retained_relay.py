"""A commit's retained views travel to the other server processes (events.pg_fanout) and
are kept there only while they can be the newest state (events.hub)."""

from __future__ import annotations

import json
import random
import string

import pytest

from chameleons.backend.events.hub import RESYNC, LiveHub
from chameleons.backend.events.pg_fanout import MAX_PAYLOAD, decode_retained, encode_retained
from chameleons.backend.events.repository import GONE

CHANNEL = "session:7"


def _views(version: int, text: str = "state") -> dict[str, dict[str, object]]:
    return {"console": {"version": version, "snapshot": {"text": text}},
            "phone": {"version": version, "state": {"view": "ranking"}}}  # fmt: skip


def test_small_views_go_as_json_and_come_back_equal() -> None:
    payload = encode_retained("me", CHANNEL, _views(3))
    assert payload is not None
    body = json.loads(payload)
    assert (body["o"], body["r"], "z" in body) == ("me", CHANNEL, False)
    assert decode_retained(body) == _views(3)


def test_a_console_sized_state_goes_compressed_within_notifys_limit() -> None:
    # About 12 kB of JSON, repetitive as a console's state is (items, prompts, events).
    items = [{"id": f"item-{i}", "label": f"Item number {i}", "rank": i} for i in range(150)]
    views = {"console": {"version": 9, "snapshot": {"items": items}}}
    assert len(json.dumps(views)) > MAX_PAYLOAD
    payload = encode_retained("me", CHANNEL, views)
    assert payload is not None
    assert len(payload.encode()) <= MAX_PAYLOAD
    body = json.loads(payload)
    assert "z" in body
    assert "v" not in body
    assert decode_retained(body) == views


def test_views_too_large_even_compressed_are_not_sent() -> None:
    noise = "".join(random.Random(1).choices(string.ascii_letters, k=4 * MAX_PAYLOAD))
    assert encode_retained("me", CHANNEL, {"console": {"version": 1, "text": noise}}) is None


@pytest.fixture
def hub() -> LiveHub:
    return LiveHub()


def test_a_peers_older_views_do_not_replace_newer_ones_kept_here(hub: LiveHub) -> None:
    hub.retain(CHANNEL, _views(5, "mine"))
    hub.retain_from_peer(CHANNEL, _views(4, "older"))
    assert hub.retained(CHANNEL, "console") == _views(5, "mine")["console"]
    hub.retain_from_peer(CHANNEL, _views(6, "newer"))
    assert hub.retained(CHANNEL, "console") == _views(6, "newer")["console"]


@pytest.mark.parametrize("message", [RESYNC, GONE])
def test_a_peers_resync_or_gone_drops_the_views_kept(hub: LiveHub, message: dict[str, str]) -> None:
    hub.retain_from_peer(CHANNEL, _views(2))
    hub.deliver("session:8", message)  # another session's: this one's stay
    assert hub.retained(CHANNEL, "phone") is not None
    hub.deliver(CHANNEL, message)
    assert hub.retained(CHANNEL, "phone") is None
    assert hub.retained(CHANNEL, "console") is None
