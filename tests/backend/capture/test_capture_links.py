"""The capture page's keyed link: the right key opens the page (with the policy MediaPipe's
wasm needs, the camera allowed), a wrong, a display or a rotated key opens nothing, and
the WebSocket refuses what the page refuses. Without a worker the page hears so."""

from __future__ import annotations

import json
import struct
from collections.abc import Callable
from typing import Any

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import Engine
from starlette.websockets import WebSocketDisconnect

from chameleons.backend.capture import current_capture_path
from chameleons.backend.db import session_scope
from chameleons.backend.display import links as display_links
from chameleons.backend.display.tokens import capture_token, display_token, signing_key
from chameleons.backend.logredact import redact
from tests.backend.test_auth import add_user, login

BOOTH = "booth-1"


def test_the_right_key_opens_the_page_and_others_do_not(client: TestClient, app: FastAPI) -> None:
    path = current_capture_path(app, BOOTH)
    assert path == f"/capture/{BOOTH}/{capture_token(signing_key(app), BOOTH)}"
    page = client.get(path)
    assert page.status_code == 200
    assert "Webcam capture: booth-1" in page.text
    assert "/static/vendor/mediapipe-face-mesh/face_mesh.js" in page.text
    policy = page.headers["content-security-policy"]
    assert "'wasm-unsafe-eval'" in policy
    assert "connect-src 'self'" in policy  # no CDN
    assert page.headers["permissions-policy"] == "camera=(self)"
    assert page.headers["referrer-policy"] == "no-referrer"
    display = display_token(signing_key(app), BOOTH)
    for wrong in ("not-the-key", display, capture_token(signing_key(app), "booth-2")):
        assert client.get(f"/capture/{BOOTH}/{wrong}").status_code == 404
    assert client.get("/capture/bad booth/x").status_code == 404
    assert redact(f"GET {path} HTTP/1.1") == f"GET /capture/{BOOTH}/<token> HTTP/1.1"


def test_rotating_the_display_link_rotates_the_capture_link(
    client: TestClient, app: FastAPI, engine: Engine
) -> None:
    old = current_capture_path(app, BOOTH)
    with session_scope(app.state.sessionmaker) as db:
        display_links.rotate(db, BOOTH)
    new = current_capture_path(app, BOOTH)
    assert new != old
    assert client.get(str(old)).status_code == 404
    assert client.get(str(new)).status_code == 200
    with session_scope(app.state.sessionmaker) as db:
        display_links.retire(db, BOOTH)
    assert current_capture_path(app, BOOTH) is None
    assert client.get(str(new)).status_code == 404


def test_the_socket_refuses_a_wrong_key_and_tells_the_page_when_no_worker_runs(
    client: TestClient, app: FastAPI
) -> None:
    for query in ("", "?token=wrong", f"?token={display_token(signing_key(app), BOOTH)}"):
        with (
            pytest.raises(WebSocketDisconnect) as refused,
            client.websocket_connect(f"/ws/capture/{BOOTH}{query}") as socket,
        ):
            socket.receive_text()
        assert refused.value.code == 1008
    token = capture_token(signing_key(app), BOOTH)
    with client.websocket_connect(f"/ws/capture/{BOOTH}?token={token}") as socket:
        assert json.loads(socket.receive_text()) == {"type": "hello", "booth": BOOTH}
        socket.send_text(json.dumps({"type": "ping", "t": 12.5}))
        assert next_of(socket, "pong") == {"type": "pong", "t": 12.5}
        socket.send_bytes(b"not a face frame")  # counted and dropped, the socket stays
        socket.send_text("not json")
        socket.send_text(json.dumps({"type": "calibrate", "action": "start"}))
        answer = next_of(socket, "calibration")
        assert answer["calibrated"] is False
        assert "No worker bridge" in answer["problem"]
        socket.send_bytes(struct.pack("<5d", 0.0, 1.0, 640, 480, 468) + bytes(468 * 12))
        report = next_of(socket, "relay", lambda r: r["frames"] == 1)
        assert report["worker"] is False
        assert report["unrelayed"] >= 1  # no bridge: nothing went on
        assert report["refused"] == 2


def next_of(socket: Any, kind: str, wanted: Callable[[dict[str, Any]], bool] | None = None
            ) -> dict[str, Any]:  # fmt: skip
    """The next message of ``kind`` (the once-a-second reports come in between)."""
    while True:
        message: dict[str, Any] = json.loads(socket.receive_text())
        if message["type"] == kind and (wanted is None or wanted(message)):
            return message


def test_the_booth_check_shows_the_capture_link_and_its_qr_code_to_staff(
    client: TestClient, app: FastAPI, engine: Engine
) -> None:
    assert client.get(f"/api/capture/{BOOTH}/qr.svg", follow_redirects=False).status_code in (
        303, 401, 403,
    )  # fmt: skip
    add_user(engine, "wiz", "a long wizard password", "wizard")
    login(client, "wiz", "a long wizard password")
    page = client.get(f"/booths/{BOOTH}/check").text
    url = f"http://testserver{current_capture_path(app, BOOTH)}"  # the address asked for
    assert f'<a id="capture-link" href="{url}">' in page
    assert "camera busy" in page
    qr = client.get(f"/api/capture/{BOOTH}/qr.svg")
    assert qr.status_code == 200
    assert qr.headers["content-type"] == "image/svg+xml"
    assert b"Webcam capture link" in qr.content
    assert client.get("/api/capture/bad booth/qr.svg").status_code == 404


def test_an_open_page_is_closed_when_its_link_is_rotated(client: TestClient, app: FastAPI) -> None:
    token = capture_token(signing_key(app), BOOTH)
    with client.websocket_connect(f"/ws/capture/{BOOTH}?token={token}") as socket:
        assert json.loads(socket.receive_text())["type"] == "hello"
        next_of(socket, "relay")  # served: the reports come
        with session_scope(app.state.sessionmaker) as db:
            display_links.rotate(db, BOOTH)
        with pytest.raises(WebSocketDisconnect) as closed:
            read_until_closed(socket)
    assert closed.value.code == 1008


def read_until_closed(socket: Any) -> None:
    """The reports, until the server closes the socket (raises WebSocketDisconnect)."""
    while True:
        socket.receive_text()


def test_the_display_links_page_lists_each_booths_capture_link(
    client: TestClient, app: FastAPI, engine: Engine
) -> None:
    add_user(engine, "wiz2", "a long wizard password", "wizard")
    login(client, "wiz2", "a long wizard password")
    page = client.get("/display").text
    url = f"{app.state.settings.effective_public_url}{current_capture_path(app, BOOTH)}"
    assert f'<a href="{url}" data-capture="{BOOTH}">' in page
