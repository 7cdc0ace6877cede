"""The phone link, the short code, the end of a session, and the live WebSockets."""

from __future__ import annotations

import random
from typing import Any

import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from chameleons.backend.events.hub import session_channel
from tests.backend.sessions.conftest import refused
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, run_session


def test_the_link_opens_the_session_page_without_login(
    app: Any, wizard: WizardBot, phone: ParticipantBot
) -> None:
    with TestClient(app) as participant:  # no staff cookie
        page = participant.get(wizard.phone_path)
    assert page.status_code == 200
    assert 'id="initial-state"' in page.text
    assert '"view":"consent"' in page.text.replace(" ", "")  # the consent page comes first
    assert page.headers["cache-control"] == "no-store"
    assert page.headers["referrer-policy"] == "no-referrer"
    assert phone.http.get("/p/not-a-real-token").status_code == 404


def test_the_short_code_leads_to_the_link(app: Any, wizard: WizardBot) -> None:
    code = wizard.snapshot["phone"]["short_code"]
    with TestClient(app) as participant:
        assert participant.get("/join").status_code == 200
        typed = f" {code[:3].lower()} {code[3:]} "
        response = participant.post("/join", data={"code": typed}, follow_redirects=False)
        assert response.status_code == 303
        assert response.headers["location"] == wizard.phone_path
        wrong = participant.post("/join", data={"code": "AAAAAA"})
        assert wrong.status_code == 404
        assert "does not belong to a running session" in wrong.text


def test_a_complete_session_link_stops_working_but_replays_still_answer(
    client: TestClient, pi: StaffApi, study_id: int
) -> None:
    result = run_session(pi, client, study_id, random.Random(8))
    wizard = WizardBot(pi, result.session_id, result.snapshot)
    phone = result.participant
    page = client.get(wizard.phone_path)
    assert page.status_code == 410
    assert "This session has ended" in page.text
    state = client.get(f"/api/phone/{wizard.token}/state")
    assert state.status_code == 410
    assert state.json()["detail"] == "This session has ended. Thank you for taking part!"
    assert phone.state() == {"view": "ended"}
    final = phone.sent[-1]
    replay = phone.submit_questionnaire(
        0, final["questionnaire"], final["answers"], client_id=final["client_id"]
    )
    assert replay["duplicate"] is True
    assert replay["state"]["view"] == "ended"
    message = refused(lambda: phone.submit_questionnaire(0, "final", final["answers"]), 410)
    assert message == "This session has ended. Thank you for taking part!"
    code = wizard.snapshot["phone"]["short_code"]
    assert client.post("/join", data={"code": code}).status_code == 404


def test_the_phone_socket_follows_the_session_and_closes_at_the_end(
    client: TestClient, wizard: WizardBot, phone: ParticipantBot
) -> None:
    with client.websocket_connect(f"/ws/p/{wizard.token}") as socket:
        assert socket.receive_json()["state"]["view"] == "consent"
        wizard.start()  # the participant consents and answers the questions before
        views = _views_until(socket, "waiting")
        assert views[-1] == "waiting"
        assert wizard.refresh()["phone"]["connected"] is True
        wizard.advance(1, "discussion")
        state = _state_until(socket, "listen")
        assert state["robot_name"] == wizard.interaction(1)["robot_name"]
        socket.send_json({"type": "ping"})
        assert _until(socket, lambda m: m.get("type") == "pong") == {"type": "pong"}
    with (
        pytest.raises(WebSocketDisconnect) as closed,
        client.websocket_connect("/ws/p/nope") as bad,
    ):
        bad.receive_json()
    assert closed.value.code == 4404


def test_the_wizard_socket_needs_login_and_streams_events_and_snapshots(
    app: Any, client: TestClient, wizard: WizardBot
) -> None:
    path = f"/ws/sessions/{wizard.session_id}"
    with (
        TestClient(app) as stranger,
        pytest.raises(WebSocketDisconnect) as refused_socket,
        stranger.websocket_connect(path) as socket,
    ):
        socket.receive_json()
    assert refused_socket.value.code == 4401
    with client.websocket_connect(path) as socket:
        first = socket.receive_json()
        assert first["type"] == "snapshot"
        assert first["session"]["state"] == "pending"
        wizard.start()  # after the participant's consent and answers (events too)
        event = _until(socket, lambda m: m["type"] == "event")
        assert event["event"]["kind"] == "consent.given"
        started = _until(
            socket, lambda m: m["type"] == "event" and m["event"]["kind"] == "session.started"
        )
        assert started["event"]["source"] == "wizard"
        snapshot = _until(socket, lambda m: m["type"] == "snapshot")
        assert snapshot["session"]["state"] == "running"
        channel = session_channel(wizard.session_id)
        app.state.live_hub.publish(channel, {"type": "telemetry", "fps": 60})
        assert socket.receive_json() == {"type": "telemetry", "fps": 60}


def _until(socket: Any, matches: Any, limit: int = 20) -> dict[str, Any]:
    for _ in range(limit):
        message: dict[str, Any] = socket.receive_json()
        if matches(message):
            return message
    raise AssertionError("the expected message did not arrive")


def _state_until(socket: Any, view: str) -> dict[str, Any]:
    message = _until(socket, lambda m: m.get("type") == "state" and m["state"]["view"] == view)
    state: dict[str, Any] = message["state"]
    return state


def _views_until(socket: Any, view: str) -> list[str]:
    views: list[str] = []
    while not views or views[-1] != view:
        message = socket.receive_json()
        views.append(message["state"]["view"])
        assert len(views) < 20
    return views
