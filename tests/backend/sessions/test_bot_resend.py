"""The participant bot (rehearsals, the bench's phones) sends a submission again when the
server closed the kept-alive connection it went out on, as the phone's page does: with the
same client id, so the server stores it once.

The peer is a plain HTTP/1.1 server on a loopback socket that does what uvicorn does to a
connection idle past its keep-alive (``timeout_keep_alive``, 5 s): it closes it, here at
the moment the next request arrives on it, without an answer. httpx then raises
``RemoteProtocolError`` ("Server disconnected without sending a response")."""

from __future__ import annotations

import json
import socket
import threading
from collections.abc import Iterator

import httpx
import pytest

from chameleons.backend.sessions.bot import ParticipantBot

RECEIPT = {"saved": True, "duplicate": False, "state": {"view": "wait"}}


class ClosingPeer:
    """Answers a connection's first request; closes it when a second one comes on it."""

    def __init__(self, *, answers: bool = True) -> None:
        self.answers = answers  # False: every request is dropped, even a connection's first
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.requests: list[tuple[str, bytes]] = []  # (request line, body)
        self.dropped = 0
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        while True:
            try:
                connection, _ = self.listener.accept()
            except OSError:
                return  # closed
            threading.Thread(target=self._connection, args=(connection,), daemon=True).start()

    def _connection(self, connection: socket.socket) -> None:
        with connection, connection.makefile("rb") as reader:
            answered = 0
            while True:
                line = reader.readline()
                if not line:
                    return
                length = 0
                while (header := reader.readline()) not in (b"\r\n", b""):
                    name, _, value = header.decode("latin-1").partition(":")
                    if name.strip().lower() == "content-length":
                        length = int(value)
                body = reader.read(length)
                if answered or not self.answers:  # idle too long: gone, as it arrives
                    self.dropped += 1
                    return
                self.requests.append((line.decode("latin-1").strip(), body))
                payload = json.dumps(RECEIPT if body else {"view": "ranking"}).encode()
                head = b"HTTP/1.1 200 OK\r\ncontent-type: application/json\r\n"
                connection.sendall(head + b"content-length: %d\r\n\r\n" % len(payload) + payload)
                answered += 1

    def close(self) -> None:
        self.listener.close()


@pytest.fixture
def peer() -> Iterator[ClosingPeer]:
    running = ClosingPeer()
    yield running
    running.close()


def test_a_submission_on_a_connection_the_server_let_go_is_sent_again_once(
    peer: ClosingPeer,
) -> None:
    with httpx.Client(base_url=f"http://127.0.0.1:{peer.port}") as http:
        bot = ParticipantBot(http, "token")
        assert bot.state() == {"view": "ranking"}  # the connection is kept alive after this
        receipt = bot.submit_ranking(1, ["a", "b"], client_id="c-1")

    assert receipt == RECEIPT
    assert peer.dropped == 1
    posts = [json.loads(body) for line, body in peer.requests if line.startswith("POST")]
    # Stored once by the server, sent once more by the bot, with the same client id.
    assert posts == [{"client_id": "c-1", "position": 1, "ranking": ["a", "b"]}]
    assert [line for line, _ in peer.requests] == [
        "GET /api/phone/token/state HTTP/1.1",
        "POST /api/phone/token/ranking HTTP/1.1",
    ]


def test_a_server_that_drops_the_second_try_too_is_still_an_error() -> None:
    """Only one more try: a server that answers nothing is reported, not hidden."""
    peer = ClosingPeer(answers=False)
    try:
        with httpx.Client(base_url=f"http://127.0.0.1:{peer.port}") as http:
            bot = ParticipantBot(http, "token")
            with pytest.raises(httpx.RemoteProtocolError):
                bot.submit_ranking(1, ["a"], client_id="c-2")
    finally:
        peer.close()
    assert peer.dropped == 2
