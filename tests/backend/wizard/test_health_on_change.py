"""The console's health goes out when it changes, not once a second (issue 34): through a
real uvicorn server and WebSocket, an unchanged health sends nothing however often it is
looked at, and a change (the server gains its worker bridge) arrives at the next look."""

from __future__ import annotations

import json
import threading
from typing import Any

import pytest
from fastapi import FastAPI
from websockets.sync.client import ClientConnection, connect
from websockets.sync.connection import Connection

from chameleons.backend.bridge import Bridge
from chameleons.backend.wizard import health
from chameleons.backend.wizard import live as wizard_live
from tests.support.bots import WizardBot
from tests.support.live_server import LiveServer

WAIT_S = 60.0
LOOKS = 30  # health looks with nothing changing


class CountingTracker(health.HealthTracker):
    """The real tracker, counting its looks (the test waits for looks, not for time)."""

    def __init__(self) -> None:
        super().__init__()
        self.looks = 0
        self.looked = threading.Condition()

    def snapshot(self, *args: Any, **kwargs: Any) -> dict[str, Any]:
        found = super().snapshot(*args, **kwargs)
        with self.looked:
            self.looks += 1
            self.looked.notify_all()
        return found

    def wait_for_looks(self, count: int) -> None:
        with self.looked:
            assert self.looked.wait_for(lambda: self.looks >= count, WAIT_S), self.looks


@pytest.fixture
def tracker(app: FastAPI, monkeypatch: pytest.MonkeyPatch) -> CountingTracker:
    monkeypatch.setattr(wizard_live, "HEALTH_INTERVAL_SECONDS", 0.005)  # many looks, fast
    found = app.state.wizard_health = CountingTracker()
    return found


def _console(live: LiveServer, wizard: WizardBot) -> ClientConnection:
    cookies = "; ".join(f"{k}={v}" for k, v in wizard.staff.http.cookies.items())
    return connect(f"ws://127.0.0.1:{live.port}/ws/wizard/sessions/{wizard.session_id}",
                   open_timeout=WAIT_S, additional_headers={"Origin": live.url,
                                                            "Cookie": cookies})  # fmt: skip


def _health_until_pong(socket: Connection) -> list[dict[str, Any]]:
    """The health messages before the answer to a ping sent now (the socket's order)."""
    socket.send(json.dumps({"type": "ping"}))
    found = []
    while (message := json.loads(socket.recv(timeout=WAIT_S)))["type"] != "pong":
        if message["type"] == "health":
            found.append(message)
    return found


def test_an_unchanged_health_sends_nothing_and_a_change_arrives(
    app: FastAPI, wizard: WizardBot, tracker: CountingTracker
) -> None:
    with LiveServer(app) as live, _console(live, wizard) as socket:
        first = _health_until_pong(socket)
        tracker.wait_for_looks(1)
        looks = tracker.looks
        assert len(first) <= 1  # the health on connect (unless it came after the pong)
        tracker.wait_for_looks(looks + LOOKS)
        # The worker has been unreachable all along: its failing_for grew, nothing else.
        later = _health_until_pong(socket)
        assert len(first) + len(later) == 1, (first, later)
        checks = {c["id"]: c for c in (first + later)[0]["checks"]}
        assert checks["worker"]["failing_for"] is not None
        # The server gains its worker bridge (no worker on it yet): the next looks see it.
        app.state.bridge = Bridge("tcp://127.0.0.1:*", "tcp://127.0.0.1:*")
        tracker.wait_for_looks(tracker.looks + 2)  # a whole look after the change
        changed = _health_until_pong(socket)
        assert [message["bridge"] for message in changed] == [True]
        assert (first + later)[0]["bridge"] is False
