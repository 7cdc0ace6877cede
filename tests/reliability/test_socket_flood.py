"""Through a real uvicorn server and raw TCP sockets: a display client that floods pings and
never reads, and one that stops reading what the server sends, are both disconnected (with
a logged reason) while another page of the same booth gets every update.

The flooder speaks RFC 6455 by hand (masked text frames, no reads at all), because every
client library reads in the background. The test waits on events only (no timing
thresholds).
"""

from __future__ import annotations

import base64
import json
import os
import socket
import struct
import threading
import time
from collections.abc import Callable, Iterator

import pytest
from fastapi import FastAPI
from websockets.sync.client import ClientConnection, connect

from chameleons.backend.display.channel import get_display_channel
from chameleons.backend.display.protocol import play_audio_message, set_face_message
from chameleons.backend.display.tokens import display_token, signing_key
from tests.support.live_server import LiveServer

BOOTH = "booth-1"
DEADLINE = 120.0  # generous: only a broken guard comes near it


@pytest.fixture
def database_url(sqlite_template: object, tmp_path: object) -> str:
    """The display socket touches no database: SQLite is enough."""
    import shutil
    from pathlib import Path

    path = Path(str(tmp_path)) / "flood.sqlite3"
    shutil.copyfile(str(sqlite_template), path)
    return f"sqlite:///{path}"


def wait_for(condition: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + DEADLINE
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.01)


def text_frame(text: str) -> bytes:
    """A client's masked text frame (RFC 6455 section 5.2)."""
    payload = text.encode()
    mask = os.urandom(4)
    n = len(payload)
    short = n < 126
    header = struct.pack("!BB", 0x81, 0x80 | n) if short else struct.pack("!BBH", 0x81, 0xFE, n)
    return header + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload))


def raw_client(port: int, path: str) -> socket.socket:
    """Open a WebSocket by hand; read the handshake response and nothing else, ever."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # fills up fast
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        (
            f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            "Sec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    response = b""
    while b"\r\n\r\n" not in response:
        chunk = sock.recv(1)
        assert chunk, "the server closed the handshake"
        response += chunk
    assert response.startswith(b"HTTP/1.1 101"), response
    return sock


class Reader:
    """A well-behaved page: reads everything in a thread and remembers it."""

    def __init__(self, url: str) -> None:
        self.messages: list[dict[str, object]] = []
        self._socket: ClientConnection = connect(url, max_size=None)
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        try:
            for raw in self._socket:
                self.messages.append(json.loads(raw))
        except Exception:  # the test closes the socket
            return

    def saw(self, predicate: Callable[[dict[str, object]], bool]) -> bool:
        return any(predicate(m) for m in list(self.messages))

    def close(self) -> None:
        self._socket.close()
        self._thread.join(timeout=DEADLINE)


@pytest.fixture
def server(app: FastAPI) -> Iterator[LiveServer]:
    with LiveServer(app) as live:
        yield live


def _path(app: FastAPI) -> str:
    return f"/ws/display/{BOOTH}?token={display_token(signing_key(app), BOOTH)}"


def _flood(sock: socket.socket, count: int, sent: threading.Event) -> None:
    frame = text_frame('{"type":"ping","id":1,"t":0}')
    try:
        for k in range(count):
            sock.sendall(frame)
            if k == 1000:
                sent.set()
    except OSError:  # the server cut us off, as it should
        pass
    finally:
        sent.set()


def test_a_ping_flood_that_never_reads_is_cut_off_and_others_still_get_updates(
    app: FastAPI, server: LiveServer, caplog: pytest.LogCaptureFixture
) -> None:
    counters = app.state.socket_guard_counters
    reader = Reader(f"ws://127.0.0.1:{server.port}{_path(app)}")
    wait_for(lambda: reader.saw(lambda m: m["type"] == "hello"), "the reader's hello")
    flooder = raw_client(server.port, _path(app))
    sent = threading.Event()
    flood = threading.Thread(target=_flood, args=(flooder, 20_000, sent), daemon=True)
    with caplog.at_level("WARNING", logger="chameleons.backend.events.guard"):
        flood.start()
        sent.wait(DEADLINE)
        get_display_channel(app).publish(BOOTH, set_face_message("face-3"))
        wait_for(lambda: reader.saw(lambda m: m.get("face") == "face-3"), "the reader's update")
        wait_for(lambda: counters["closed.1008"] >= 1, "the flooder's disconnect")
    flood.join(DEADLINE)
    flooder.close()
    reader.close()
    logged = [r.getMessage() for r in caplog.records]
    assert any(f"/ws/display/{BOOTH} from 127.0.0.1" in m and "(1008)" in m for m in logged)
    assert counters["closed.1013"] == 0  # the reader was never taken for a slow client


def test_a_page_that_stops_reading_is_shed_and_the_other_page_gets_everything(
    app: FastAPI, server: LiveServer, caplog: pytest.LogCaptureFixture
) -> None:
    counters = app.state.socket_guard_counters
    channel = get_display_channel(app)
    reader = Reader(f"ws://127.0.0.1:{server.port}{_path(app)}")
    stalled = raw_client(server.port, _path(app))  # reads nothing from here on
    wait_for(lambda: channel.connected(BOOTH) == 2, "both pages")
    url = "/media/" + "x" * 2000 + ".mp3"  # big commands fill the TCP window quickly
    published = 0
    with caplog.at_level("WARNING", logger="chameleons.backend.events.guard"):
        while counters["closed.1013"] == 0:
            channel.publish(BOOTH, play_audio_message(f"p#{published}", url))
            published += 1
            if published % 50 == 0:
                # Let the loop and the reader catch up (an event, not a pause): the reader
                # has had everything so far.
                last = f"p#{published - 1}"

                def caught_up(last: str = last) -> bool:
                    seen = reader.saw(lambda m: m.get("play_id") == last)
                    return seen or counters["closed.1013"] > 0

                wait_for(caught_up, "the reader to catch up")
            assert published < 100_000, "the stalled page was never shed"
        channel.publish(BOOTH, set_face_message("face-4"))
        wait_for(lambda: reader.saw(lambda m: m.get("face") == "face-4"), "the last update")
    wait_for(lambda: channel.connected(BOOTH) == 1, "the stalled page to be gone")
    ids = [m["play_id"] for m in reader.messages if m["type"] == "play_audio"]
    assert ids == [f"p#{k}" for k in range(published)]  # nothing lost, in order
    assert any("(1013): client is not reading" in r.getMessage() for r in caplog.records)
    stalled.close()
    reader.close()
