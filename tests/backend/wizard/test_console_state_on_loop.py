"""A console woken by a phone's answer takes the state that answer committed on the event
loop, without a trip through the thread pool (issue 34); a change whose state the hub does
not keep (a note) is still read in a thread. Through a real uvicorn server and WebSocket."""

from __future__ import annotations

import json
from typing import Any

import pytest
from fastapi import FastAPI
from websockets.sync.client import ClientConnection, connect
from websockets.sync.connection import Connection

from chameleons.backend.wizard import live as wizard_live
from chameleons.backend.wizard import playback
from tests.support.bots import ParticipantBot, WizardBot
from tests.support.live_server import LiveServer

WAIT_S = 60.0
RANKED = "ranking.submitted"


def _console(live: LiveServer, wizard: WizardBot) -> ClientConnection:
    cookies = "; ".join(f"{k}={v}" for k, v in wizard.staff.http.cookies.items())
    return connect(f"ws://127.0.0.1:{live.port}/ws/wizard/sessions/{wizard.session_id}",
                   open_timeout=WAIT_S, additional_headers={"Origin": live.url,
                                                            "Cookie": cookies})  # fmt: skip


def _state_after(socket: Connection, version: int) -> dict[str, Any]:
    """The next console state of ``version`` (health and event messages skipped)."""
    while True:
        message = json.loads(socket.recv(timeout=WAIT_S))
        if message["type"] == "console" and message["session"]["version"] >= version:
            return dict(message)


def _state_with(socket: Connection, kind: str) -> dict[str, Any]:
    """The first console state whose new events include one of ``kind``."""
    while True:
        state = _state_after(socket, 0)
        if any(event["kind"] == kind for event in state["events"]):
            return state


def test_a_phones_answer_reaches_the_console_without_a_thread_read(
    app: FastAPI, wizard: WizardBot, phone: ParticipantBot, monkeypatch: pytest.MonkeyPatch
) -> None:
    reads: list[str] = []

    def counted(state: Any, work: Any, *args: Any) -> Any:
        if work is wizard_live._state_message:
            reads.append("state")
        return playback.read(state, work, *args)

    monkeypatch.setattr(wizard_live, "read", counted)
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    with LiveServer(app) as live, _console(live, wizard) as socket:
        _state_after(socket, 0)
        assert reads == ["state"]  # the first state: read
        ranking = list(wizard.interaction(1)["presented_order"])
        phone.submit_ranking(1, ranking)
        state = _state_with(socket, RANKED)
        assert reads == ["state"]  # the state the answer committed, kept: not read
        assert state["events_delta"] is True
        assert state["session"]["interactions"][0]["initial_ranking"] == ranking
        wizard.staff.post(f"/api/sessions/{wizard.session_id}/notes", {"text": "laughed"})
        _state_with(socket, "wizard.note")
        # A note keeps no state: read in a thread (at least once; on a busy machine another
        # wake-up, a late notification of the same commits, may read once more).
        assert len(reads) >= 2
        assert set(reads) == {"state"}
