"""Through a real uvicorn server and raw TCP sockets: a display client that floods pings and
never reads, and one that stops reading what the server sends, are both disconnected (with
a logged reason) while another page of the same booth gets every update; so are a phone,
a console and a console's live feed that stop reading, while another of their kind on the
same session carries on.

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

import httpx
import pytest
from fastapi import FastAPI
from sqlalchemy import Engine
from websockets.sync.client import ClientConnection, connect

from chameleons.backend.display.channel import get_display_channel
from chameleons.backend.display.protocol import play_audio_message, set_face_message
from chameleons.backend.display.tokens import display_token, signing_key
from chameleons.backend.events.hub import session_channel
from chameleons.backend.sessions.snapshot import phone_presence_key
from tests.support.bots import WizardBot, staff_api, study_with_plan
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


def raw_client(port: int, path: str, headers: str = "") -> socket.socket:
    """Open a WebSocket by hand; read the handshake response and nothing else, ever.
    ``headers``: more request header lines, each ending in CRLF (a staff cookie)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # fills up fast
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        (
            f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            f"Sec-WebSocket-Version: 13\r\n{headers}\r\n"
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

    def __init__(self, url: str, headers: dict[str, str] | None = None) -> None:
        self.messages: list[dict[str, object]] = []
        self._socket: ClientConnection = connect(
            url, max_size=None, additional_headers=headers, open_timeout=DEADLINE
        )
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


# --- phones, consoles and live feeds ---------------------------------------------------
# The same guard on the session sockets: a client that stops reading is shed with 1013
# (after ws_send_timeout_s) while another client of the same session gets every update.

BLOB = "x" * 2000  # big messages fill the stalled client's TCP window quickly


@pytest.fixture
def tight_server(app: FastAPI) -> Iterator[LiveServer]:
    """A server with small socket send buffers: a phone's state is ~1 kB, and megabytes of
    them (the kernel's autotuned buffer) would take longer than uvicorn's own keepalive
    (ping unanswered: closed after ~40 s), which would then shed the client before the
    guard under test."""
    with LiveServer(app, send_buffer=16_384) as live:
        yield live


@pytest.fixture
def staff_cookie(tight_server: LiveServer, engine: Engine) -> Iterator[tuple[WizardBot, str]]:
    """A session of the default study, and the PI's login cookie for its sockets."""
    with httpx.Client(base_url=tight_server.url, timeout=DEADLINE) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi))
        yield wizard, "; ".join(f"{k}={v}" for k, v in http.cookies.items())


def _shed(
    app: FastAPI, push: Callable[[int], None], caught_up: Callable[[int], bool], every: int = 50
) -> int:
    """Push updates until the guard sheds a client (1013); let the reader catch up after
    each ``every`` (an event, not a pause). Returns how many were pushed."""
    counters = app.state.socket_guard_counters
    pushed = 0
    while counters["closed.1013"] == 0:
        push(pushed)
        pushed += 1
        if pushed % every == 0:

            def breathed(last: int = pushed - 1) -> bool:
                return caught_up(last) or counters["closed.1013"] > 0

            wait_for(breathed, "the reader to catch up")
        assert pushed < 100_000, "the stalled client was never shed"
    return pushed


@pytest.mark.parametrize("kind", ["console", "feed"])
def test_a_console_that_stops_reading_is_shed_and_the_other_console_gets_everything(
    app: FastAPI,
    tight_server: LiveServer,
    staff_cookie: tuple[WizardBot, str],
    caplog: pytest.LogCaptureFixture,
    kind: str,
) -> None:
    wizard, cookie = staff_cookie
    session_id = wizard.session_id
    path = {"console": f"/ws/wizard/sessions/{session_id}", "feed": f"/ws/sessions/{session_id}"}
    headers = {"Origin": tight_server.url, "Cookie": cookie}
    hub, channel = app.state.live_hub, session_channel(session_id)
    reader = Reader(f"ws://127.0.0.1:{tight_server.port}{path[kind]}", headers)
    stalled = raw_client(
        tight_server.port, path[kind], "".join(f"{k}: {v}\r\n" for k, v in headers.items())
    )
    wait_for(lambda: hub.subscriber_count(channel) == 2, "both consoles")

    def saw(n: object) -> bool:
        return reader.saw(lambda m: m.get("type") == "telemetry" and m.get("n") == n)

    with caplog.at_level("WARNING", logger="chameleons.backend.events.guard"):
        pushed = _shed(
            app, lambda n: hub.publish(channel, {"type": "telemetry", "n": n, "blob": BLOB}), saw
        )
        hub.publish(channel, {"type": "telemetry", "n": "last"})
        wait_for(lambda: saw("last"), "the last update")
    wait_for(lambda: hub.subscriber_count(channel) == 1, "the stalled console to be gone")
    got = [m["n"] for m in reader.messages if m.get("type") == "telemetry"]
    assert got == [*range(pushed), "last"]  # nothing lost, in order
    assert any("(1013): client is not reading" in r.getMessage() for r in caplog.records)
    stalled.close()
    reader.close()


def test_a_phone_that_stops_reading_is_shed_and_the_other_phone_carries_on(
    app: FastAPI,
    tight_server: LiveServer,
    staff_cookie: tuple[WizardBot, str],
    caplog: pytest.LogCaptureFixture,
) -> None:
    wizard, _ = staff_cookie
    hub, channel = app.state.live_hub, session_channel(wizard.session_id)
    path = f"/ws/p/{wizard.token}"
    reader = Reader(f"ws://127.0.0.1:{tight_server.port}{path}?device=aaaaaaaaaaaaaaaa")
    stalled = raw_client(tight_server.port, f"{path}?device=bbbbbbbbbbbbbbbb")
    wait_for(lambda: hub.present(phone_presence_key(wizard.session_id)) == 2, "both phones")

    # Every change on the session sends each phone its whole state (~1 kB, no counter in
    # it): the reader has caught up when a state came since the last time it had. Changes
    # one at a time, so that each reaches the stalled phone too (not merged into one).
    def states() -> int:
        return sum(m.get("type") == "state" for m in list(reader.messages))

    seen = [states()]

    def caught_up(_last: int) -> bool:
        if states() <= seen[0]:
            return False
        seen[0] = states()
        return True

    def poke(_n: int) -> None:
        hub.publish(channel, {"type": "presence", "kind": "poke", "blob": BLOB})

    with caplog.at_level("WARNING", logger="chameleons.backend.events.guard"):
        _shed(app, poke, caught_up, every=1)
        wait_for(lambda: hub.present(phone_presence_key(wizard.session_id)) == 1, "one phone")
        now = states()
        poke(0)
        wait_for(lambda: states() > now, "the other phone's next state")
    assert any("/ws/p/" in r.getMessage() and "(1013)" in r.getMessage() for r in caplog.records)
    assert not any(wizard.token in r.getMessage() for r in caplog.records)  # redacted
    stalled.close()
    reader.close()
