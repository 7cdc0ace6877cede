"""The console's WebSocket: the state on connect, events and fresh state on every change,
the robot's health once a second; staff only."""

from __future__ import annotations

from typing import Any

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from chameleons.backend.events.hub import RESYNC, session_channel
from chameleons.backend.events.repository import announce_rewritten
from chameleons.backend.events.unit_of_work import write_session
from tests.backend.wizard.conftest import api
from tests.support.bots import StaffApi, WizardBot


def next_of(socket: Any, kind: str, limit: int = 20) -> dict[str, Any]:
    """The next message of type ``kind`` (health beats may come in between)."""
    for _ in range(limit):
        message: dict[str, Any] = socket.receive_json()
        if message["type"] == kind:
            return message
    raise AssertionError(f"no {kind!r} message among {limit}")


def test_the_feed_sends_state_then_events_and_fresh_state(
    client: TestClient, wizard: WizardBot
) -> None:
    with client.websocket_connect(f"/ws/wizard/sessions/{wizard.session_id}") as socket:
        first = socket.receive_json()
        assert first["type"] == "console"
        assert first["session"]["id"] == wizard.session_id
        assert first["prompt_position"] == 1
        played = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_no"})
        event = next_of(socket, "event")["event"]
        assert event["kind"] == "prompt.played"
        assert event["id"] == played["event_id"]
        fresh = next_of(socket, "console")
        # Only what is new since the first state: the console adds it to what it holds.
        assert fresh["events_delta"] is True
        assert [e["id"] for e in fresh["events"]] == [played["event_id"]]
        assert fresh["events"][0] == event
        assert first["last_event_id"] < played["event_id"]


def whole_timeline(socket: Any, seen: list[int], limit: int = 20) -> dict[str, Any]:
    """The next console state that carries the whole timeline; ids of deltas go to seen."""
    for _ in range(limit):
        message = next_of(socket, "console")
        if not message.get("events_delta"):
            return message
        seen.extend(e["id"] for e in message["events"])
    raise AssertionError("no whole timeline")


def test_a_feed_that_fell_behind_gets_the_whole_timeline_again(
    client: TestClient, wizard: WizardBot, app: FastAPI
) -> None:
    with client.websocket_connect(f"/ws/wizard/sessions/{wizard.session_id}") as socket:
        first = next_of(socket, "console")
        played = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_no"})
        delta = next_of(socket, "console")
        assert delta["events_delta"] is True
        seen = [e["id"] for e in first["events"] + delta["events"]]
        app.state.live_hub.publish(session_channel(wizard.session_id), RESYNC)
        whole = whole_timeline(socket, seen)
        ids = [e["id"] for e in whole["events"]]
        assert played["event_id"] in ids
        assert set(seen) <= set(ids)
        assert ids == sorted(ids)


def test_a_withdrawal_that_empties_quoted_events_resends_the_whole_timeline(
    client: TestClient, wizard: WizardBot
) -> None:
    """Events of *this* session quoting a withdrawn participant lose their content; an
    open console must not keep showing the old texts from its held timeline."""
    factory = client.app.state.sessionmaker  # type: ignore[attr-defined]
    hub = client.app.state.live_hub  # type: ignore[attr-defined]
    with client.websocket_connect(f"/ws/wizard/sessions/{wizard.session_id}") as socket:
        next_of(socket, "console")
        with write_session(factory, hub) as db:
            announce_rewritten(db, {wizard.session_id})
        whole = whole_timeline(socket, [])
        assert whole["events"]


def test_health_says_the_worker_is_unreachable_and_for_how_long(
    client: TestClient, wizard: WizardBot
) -> None:
    with client.websocket_connect(f"/ws/wizard/sessions/{wizard.session_id}") as socket:
        beat = next_of(socket, "health")
        assert beat["booth"] == "booth-1"
        assert beat["bridge"] is False
        assert beat["ok"] is False
        checks = {check["id"]: check for check in beat["checks"]}
        assert checks["worker"]["ok"] is False
        assert checks["worker"]["value"] == "no telemetry"
        assert checks["worker"]["failing_for"] >= 0
        assert checks["robot"]["ok"] is None  # unknown while the worker is silent


def test_the_feed_is_for_staff_only(client: TestClient, wizard: WizardBot) -> None:
    client.cookies.clear()
    with (
        pytest.raises(WebSocketDisconnect) as closed,
        client.websocket_connect(f"/ws/wizard/sessions/{wizard.session_id}") as socket,
    ):
        socket.receive_json()
    assert closed.value.code == 4401


def test_an_unknown_session_says_gone_and_closes_the_feed(
    client: TestClient, wizard: WizardBot
) -> None:
    with client.websocket_connect("/ws/wizard/sessions/987654") as socket:
        assert socket.receive_json() == {"type": "gone"}
        with pytest.raises(WebSocketDisconnect) as closed:
            socket.receive_json()
    assert closed.value.code == 4404


def test_withdrawing_the_participant_tells_the_open_feed(
    client: TestClient, wizard: WizardBot, pi: StaffApi
) -> None:
    snapshot = wizard.refresh()
    code, study = snapshot["participant"]["code"], snapshot["study_id"]
    with client.websocket_connect(f"/ws/wizard/sessions/{wizard.session_id}") as socket:
        assert socket.receive_json()["type"] == "console"
        pi.post(f"/api/pi/participants/{code}/withdraw?study={study}", {"confirm": code})
        assert next_of(socket, "gone") == {"type": "gone"}
        with pytest.raises(WebSocketDisconnect) as closed:
            next_of(socket, "no more messages")  # health beats may still be on their way
    assert closed.value.code == 4404
