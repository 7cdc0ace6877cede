"""Display links, the page, and its WebSocket through the real app (TestClient)."""

from __future__ import annotations

import json

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import Engine
from starlette.websockets import WebSocketDisconnect

from chameleons.backend.display.channel import get_display_channel
from chameleons.backend.display.protocol import Message, set_face_message
from chameleons.backend.display.tokens import display_path, display_token, signing_key
from tests.backend.test_auth import add_user, login

BOOTH = "booth-1"


@pytest.fixture
def database_url(sqlite_template: object, tmp_path: object) -> str:
    """These tests exercise links and sockets; one backend (SQLite) is enough."""
    import shutil
    from pathlib import Path

    path = Path(str(tmp_path)) / "display.sqlite3"
    shutil.copyfile(str(sqlite_template), path)
    return f"sqlite:///{path}"


def token(app: FastAPI, booth: str = BOOTH) -> str:
    return display_token(signing_key(app), booth)


def test_the_booth_link_opens_the_page_without_login(client: TestClient, app: FastAPI) -> None:
    response = client.get(display_path(signing_key(app), BOOTH))
    assert response.status_code == 200
    assert 'id="face"' in response.text
    assert f"/ws/display/{BOOTH}?token={token(app)}" in response.text
    assert response.headers["referrer-policy"] == "no-referrer"


@pytest.mark.parametrize("booth", ["booth-1", "booth-2"])
def test_a_wrong_or_foreign_token_is_not_found(
    client: TestClient, app: FastAPI, booth: str
) -> None:
    other = token(app, "booth-2")
    assert (
        client.get(f"/display/booth-1/{other if booth == 'booth-2' else 'x' * 32}").status_code
        == 404
    )


def test_tokens_depend_on_the_secret_key(app: FastAPI) -> None:
    assert display_token(b"one secret key!!", BOOTH) != display_token(b"another secret!!", BOOTH)
    assert display_token(signing_key(app), BOOTH) == token(app)  # stable for one key


def test_staff_see_every_link_and_others_are_sent_to_login(
    client: TestClient, app: FastAPI, engine: Engine
) -> None:
    assert client.get("/display", follow_redirects=False).status_code == 303
    add_user(engine, "wiz", "correct horse", "wizard")
    login(client, "wiz", "correct horse")
    page = client.get("/display", params={"booth": "booth-7"}).text
    for booth in ("booth-1", "booth-7"):
        assert display_path(signing_key(app), booth) in page
    assert 'role="alert"' in client.get("/display", params={"booth": "../x"}).text
    assert client.get("/display/booth-3").status_code == 200  # staff need no token


def receive(ws: object) -> Message:
    message: Message = json.loads(ws.receive_text())  # type: ignore[attr-defined]
    return message


def test_socket_greets_then_relays_the_booth_state(client: TestClient, app: FastAPI) -> None:
    channel = get_display_channel(app)
    channel.publish(BOOTH, set_face_message("face-4"))  # before the page connects
    with client.websocket_connect(f"/ws/display/{BOOTH}?token={token(app)}") as ws:
        hello = receive(ws)
        assert hello["type"] == "hello"
        assert hello["faces"][0] == "face-1"
        assert len(hello["blendshapes"]) == 52
        assert receive(ws) == set_face_message("face-4")
        channel.publish("booth-2", set_face_message("face-2"))  # another booth: not ours
        channel.publish(BOOTH, set_face_message("face-3"))
        assert receive(ws) == set_face_message("face-3")


def test_socket_refuses_a_wrong_token(client: TestClient, app: FastAPI) -> None:
    with (
        pytest.raises(WebSocketDisconnect),
        client.websocket_connect(f"/ws/display/{BOOTH}?token={token(app, 'booth-2')}") as ws,
    ):
        ws.receive_text()


def test_socket_takes_a_staff_cookie_from_this_site_only(
    client: TestClient, engine: Engine
) -> None:
    add_user(engine, "wiz", "correct horse", "wizard")
    login(client, "wiz", "correct horse")
    with client.websocket_connect(
        f"/ws/display/{BOOTH}", headers={"origin": "http://testserver"}
    ) as ws:
        assert receive(ws)["type"] == "hello"
    with (
        pytest.raises(WebSocketDisconnect),
        client.websocket_connect(
            f"/ws/display/{BOOTH}", headers={"origin": "http://evil.example"}
        ) as ws,
    ):
        ws.receive_text()


def test_page_reports_reach_listeners_and_garbage_is_counted(
    client: TestClient, app: FastAPI
) -> None:
    channel = get_display_channel(app)
    seen: list[tuple[str, Message]] = []
    channel.add_listener(lambda booth, message: seen.append((booth, message)))
    speech = {"type": "speech", "event": "start", "play_id": "p#1", "prompt_id": "p"}
    with client.websocket_connect(f"/ws/display/{BOOTH}?token={token(app)}") as ws:
        receive(ws)
        ws.send_text("not json")
        ws.send_text(json.dumps({"type": "speech", "event": "middle", "play_id": "p#1"}))
        ws.send_text(json.dumps(speech))
        ws.send_text(json.dumps({"type": "ping", "id": 7, "t": 12.5}))
        pong = receive(ws)  # replies come in order: the speech event was handled first
    assert (pong["type"], pong["id"], pong["t"]) == ("pong", 7, 12.5)
    assert seen == [(BOOTH, speech)]
    assert channel.counters["inbound.bad_json"] == 1
    assert channel.counters["inbound.bad_speech_event"] == 1
    # A binary frame closes the socket with 1003: tests/reliability/test_socket_guards.py
