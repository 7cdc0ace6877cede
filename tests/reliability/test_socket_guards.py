"""Every WebSocket (phone, console, live feed, robot display) refuses binary frames with
1003 and closes a client that sends more than its burst with 1008, logging why, and drops a frame
nested past the JSON parser without hanging up; the display's outgoing queue stays bounded
whatever a page fails to read."""

from __future__ import annotations

import asyncio
import json
import logging
from collections.abc import Callable

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from chameleons.backend.display.channel import Subscription
from chameleons.backend.display.protocol import face_message, play_audio_message
from chameleons.backend.display.tokens import display_token, signing_key
from chameleons.backend.events.guard import SocketClosed
from chameleons.worker.frames import N_BLENDSHAPES
from tests.backend.display.test_channel_and_relay import run
from tests.backend.sessions.conftest import phone, pi, study_id, wizard
from tests.reliability.conftest import BURST
from tests.support.bots import WizardBot
from tests.support.live_server import LiveServer

__all__ = ["phone", "pi", "study_id", "wizard"]


def _paths(app: FastAPI, wizard: WizardBot) -> dict[str, str]:
    return {
        "phone": f"/ws/p/{wizard.token}",
        "console": f"/ws/wizard/sessions/{wizard.session_id}",
        "feed": f"/ws/sessions/{wizard.session_id}",
        "display": f"/ws/display/booth-1?token={display_token(signing_key(app), 'booth-1')}",
    }


def _close_code(client: TestClient, path: str, send: Callable[[object], None]) -> int:
    def drain(socket: object) -> None:
        for _ in range(10_000):  # the greeting, pongs, health... then the close
            socket.receive_text()  # type: ignore[attr-defined]

    with client.websocket_connect(path) as socket:
        send(socket)
        with pytest.raises(WebSocketDisconnect) as closed:
            drain(socket)
    return closed.value.code


@pytest.mark.parametrize("socket", ["phone", "console", "feed", "display"])
def test_a_binary_frame_closes_the_socket_with_1003(
    client: TestClient, app: FastAPI, wizard: WizardBot, socket: str
) -> None:
    path = _paths(app, wizard)[socket]
    assert _close_code(client, path, lambda ws: ws.send_bytes(b"\x00\x01")) == 1003  # type: ignore[attr-defined]


@pytest.mark.parametrize("socket", ["phone", "console", "feed", "display"])
def test_a_client_above_its_message_rate_is_disconnected_and_logged(
    client: TestClient,
    app: FastAPI,
    wizard: WizardBot,
    socket: str,
    caplog: pytest.LogCaptureFixture,
) -> None:
    path = _paths(app, wizard)[socket]

    def flood(ws: object) -> None:
        for k in range(BURST + 5):
            ws.send_text(f'{{"type":"ping","id":{k},"t":0}}')  # type: ignore[attr-defined]

    with caplog.at_level(logging.WARNING, logger="chameleons.backend.events.guard"):
        assert _close_code(client, path, flood) == 1008
    reasons = [r.getMessage() for r in caplog.records if "closed (1008)" in r.getMessage()]
    assert reasons, "no logged reason for the disconnect"
    assert "messages at once" in reasons[0]
    assert "token=" not in reasons[0]  # the log names the path, never the credential
    assert app.state.socket_guard_counters["closed.1008"] == 1


def test_pings_within_the_burst_are_answered(
    client: TestClient, app: FastAPI, wizard: WizardBot
) -> None:
    with client.websocket_connect(_paths(app, wizard)["phone"]) as socket:
        socket.receive_json()  # the state
        for _ in range(BURST - 1):
            socket.send_text('{"type":"ping"}')
        pongs = 0
        while pongs < BURST - 1:
            pongs += socket.receive_json()["type"] == "pong"
    assert app.state.socket_guard_counters["closed.1008"] == 0


WAIT_S = 60.0  # generous: only a socket that never answers comes near it


@pytest.mark.parametrize("socket", ["phone", "console", "feed", "display"])
def test_a_frame_nested_past_the_parser_is_dropped_and_the_socket_goes_on(
    app: FastAPI, wizard: WizardBot, socket: str
) -> None:
    """4,000 nested lists (8 kB, within every socket's size limit) made the JSON parser raise
    RecursionError, a RuntimeError that ended the receive loop: the server hung up. Through
    a real uvicorn server, so a socket the server leaves is seen closed."""
    cookies = "; ".join(f"{k}={v}" for k, v in wizard.staff.http.cookies.items())
    with LiveServer(app) as live, connect(
        f"ws://127.0.0.1:{live.port}{_paths(app, wizard)[socket]}", open_timeout=WAIT_S,
        additional_headers={"Origin": live.url, "Cookie": cookies},
    ) as ws:  # fmt: skip
        ws.send("[" * 4000 + "]" * 4000)
        ws.send('{"type":"ping","id":1,"t":0}')
        try:
            while json.loads(ws.recv(timeout=WAIT_S))["type"] != "pong":
                pass  # the greeting, state, health or face frames may come first
        except ConnectionClosed as closed:
            raise AssertionError(f"the server hung up ({closed})") from None


def test_the_display_queue_stays_bounded_for_a_page_that_never_reads() -> None:
    async def scenario() -> tuple[int, int, bool]:
        subscription = Subscription("booth-1", limit=16)
        longest = 0
        for k in range(50_000):  # a day's worth of frames for a page that is gone
            subscription.put(face_message([k % 2] * N_BLENDSHAPES))
            longest = max(longest, len(subscription._items), len(subscription._frames))
        kept_going = not subscription.overflowed
        for k in range(17):  # commands are never dropped: the 17th sheds the page
            subscription.put(play_audio_message(f"p#{k}", "/a.mp3"))
        with pytest.raises(SocketClosed) as closed:
            await subscription.get()
        assert closed.value.code == 1013
        return longest, subscription.dropped, kept_going

    longest, dropped, kept_going = run(scenario())
    assert kept_going
    assert longest <= 2 * 16 + 1
    assert dropped == 50_000 - 16 + 16  # every frame but the newest 16, then those for commands
    _ = asyncio  # the scenario runs in a thread with its own loop
