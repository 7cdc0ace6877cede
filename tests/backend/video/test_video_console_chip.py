"""The console's *Participant video* chip, read from the console's own WebSocket while the
recording page's requests go through the real API (a real database, real chunk uploads):
green while chunks come, amber once a running session has had none for a while (never an
alarm), grey for a participant who declined, no chip for a study that films nobody. The
seconds since the last chunk go apart from the value, so their ticking sends nothing."""

from __future__ import annotations

from typing import Any

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.wizard import live as wizard_live
from chameleons.backend.wizard import video_health
from tests.backend.video.conftest import RunSession
from tests.backend.video.test_video_api import FIRST, chunk, start
from tests.backend.wizard.test_health_on_change import (
    CountingTracker,
    _console,
    _health_until_pong,
)
from tests.backend.wizard.test_worker_path import until
from tests.support.bots import StaffApi, WizardBot, study_with_plan
from tests.support.live_server import LiveServer

LOOKS = 30


def health(client: TestClient, wizard: WizardBot) -> dict[str, Any]:
    """The health a console opening now is sent first (the feed sends one on connect)."""
    with client.websocket_connect(f"/ws/wizard/sessions/{wizard.session_id}") as socket:
        for _ in range(20):
            message: dict[str, Any] = socket.receive_json()
            if message["type"] == "health":
                return message
    raise AssertionError("no health message")


def video_chip(client: TestClient, wizard: WizardBot) -> dict[str, Any] | None:
    return next((c for c in health(client, wizard)["checks"] if c["id"] == "video"), None)


def film(client: TestClient, key: str, wizard: WizardBot, chunks: int) -> int:
    """The recording page's requests: a video of the session and its first chunks."""
    started = start(client, key, wizard.session_id)
    assert started.status_code == 201, started.text
    video_id = int(started.json()["video_id"])
    for seq in range(chunks):
        stored = chunk(client, key, video_id, seq, FIRST if seq == 0 else b"cluster %d" % seq)
        assert stored.status_code == 200, stored.text
    return video_id


def test_recording_is_green_and_a_silent_page_amber_never_an_alarm(
    client: TestClient, booth_key: str, running: RunSession, monkeypatch: pytest.MonkeyPatch
) -> None:
    wizard = running(video=True)
    before = video_chip(client, wizard)
    assert before is not None
    assert before["label"] == "Participant video"
    # Just started (well within the 6 s the page needs to send its first chunk).
    assert (before["level"], before["value"]) == (
        "unknown", "starting: waiting for the recording page's first chunk")  # fmt: skip
    film(client, booth_key, wizard, chunks=2)
    chip = video_chip(client, wizard)
    assert chip is not None
    assert (chip["ok"], chip["level"], chip["value"]) == (True, "ok", "recording: 2 chunks")
    assert 0.0 <= chip["since_s"] < video_health.SILENT_AFTER_S
    # No chunk for longer than the page's silence limit (shortened: no fixed wait).
    monkeypatch.setattr(video_health, "SILENT_AFTER_S", 0.3)

    def amber() -> dict[str, Any] | None:
        message = health(client, wizard)
        found = next(c for c in message["checks"] if c["id"] == "video")
        return message if found["level"] == "degraded" else None

    message = until(amber, timeout=30)
    chip = next(c for c in message["checks"] if c["id"] == "video")
    assert chip["value"] == (
        "video consented but the booth's recording page is not open/recording: 2 chunks")
    assert chip["since_s"] >= 0.3
    # Amber only (the alarm line is the absent worker's, not the video's).
    assert "video" not in [c["id"] for c in message["checks"] if c["level"] == "alarm"]


def test_a_running_session_with_no_chunk_says_the_page_is_not_recording(
    client: TestClient, running: RunSession, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(video_health, "SILENT_AFTER_S", 0.0)  # the start's grace is over
    chip = video_chip(client, running(video=True))
    assert chip is not None
    assert (chip["ok"], chip["level"]) == (False, "degraded")
    assert chip["value"] == ("video consented but the booth's recording page is not "
                             "open/recording: no chunk yet")  # fmt: skip
    assert "since_s" not in chip


def test_a_participant_who_declined_is_grey_and_a_study_without_video_has_no_chip(
    client: TestClient, running: RunSession, pi: StaffApi
) -> None:
    declined = video_chip(client, running(video=False))
    assert declined is not None
    assert (declined["ok"], declined["level"], declined["value"]) == (
        None, "unknown", "not filmed: no consent")  # fmt: skip
    unfilmed = WizardBot.create(pi, study_with_plan(pi, participants=2), booth="booth-2")
    unfilmed.start()
    assert video_chip(client, unfilmed) is None


def test_the_seconds_since_the_last_chunk_send_nothing_a_new_chunk_does(
    app: FastAPI, client: TestClient, booth_key: str, running: RunSession,
    monkeypatch: pytest.MonkeyPatch,
) -> None:  # fmt: skip
    wizard = running(video=True)
    monkeypatch.setattr(wizard_live, "HEALTH_INTERVAL_SECONDS", 0.005)  # many looks, fast
    tracker = app.state.wizard_health = CountingTracker()
    # Silent at once: the chip stays amber while the seconds since the chunk grow.
    monkeypatch.setattr(video_health, "SILENT_AFTER_S", 0.0)
    video_id = film(client, booth_key, wizard, chunks=1)
    with LiveServer(app) as server, _console(server, wizard) as socket:
        first = _health_until_pong(socket)
        tracker.wait_for_looks(1)
        tracker.wait_for_looks(tracker.looks + LOOKS)
        later = _health_until_pong(socket)
        sent = first + later
        assert len(sent) == 1, sent  # the one on connect
        chip = next(c for c in sent[0]["checks"] if c["id"] == "video")
        assert chip["value"].endswith(": 1 chunk")
        # The page sends another chunk: the count changed, the next look sends it.
        assert chunk(client, booth_key, video_id, 1, b"cluster 1").status_code == 200
        tracker.wait_for_looks(tracker.looks + 2)
        changed = _health_until_pong(socket)
        assert len(changed) == 1, changed
        chip = next(c for c in changed[0]["checks"] if c["id"] == "video")
        assert chip["value"].endswith(": 2 chunks")
