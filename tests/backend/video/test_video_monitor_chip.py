"""The PI's booths monitor (``/api/pi/monitor``) shows the *Participant video* chip of each
booth as the console does (test_video_console_chip.py), from the real API and database:
green with the chunk count and the seconds since the last chunk once the recording page
uploads, amber (never an alarm, so no problem line) when it falls silent, grey for a
participant who declined, and no chip for a study that films nobody."""

from __future__ import annotations

from typing import Any

import pytest
from fastapi.testclient import TestClient

from chameleons.backend.wizard import video_health
from tests.backend.video.conftest import RunSession
from tests.backend.video.test_video_console_chip import film
from tests.support.bots import StaffApi, WizardBot, study_with_plan


def monitor_chip(pi: StaffApi, study_id: int, booth: str) -> tuple[dict[str, Any], Any]:
    """The booth's card on the monitor and its video chip (None: no chip)."""
    answer = pi.http.get("/api/pi/monitor", params={"study": study_id})
    assert answer.status_code == 200, answer.text
    card = next(b for b in answer.json()["booths"] if b["booth"] == booth)
    return card, next((c for c in card["health"]["checks"] if c["id"] == "video"), None)


def test_the_monitor_shows_the_video_chip_green_then_amber(
    client: TestClient, pi: StaffApi, video_study: int, booth_key: str, running: RunSession,
    monkeypatch: pytest.MonkeyPatch,
) -> None:  # fmt: skip
    wizard = running(video=True)
    _, chip = monitor_chip(pi, video_study, "booth-1")
    assert chip is not None
    assert (chip["label"], chip["level"], chip["value"]) == (
        "Participant video", "unknown", "starting: waiting for the recording page's first chunk")
    film(client, booth_key, wizard, chunks=3)
    _, chip = monitor_chip(pi, video_study, "booth-1")
    assert (chip["ok"], chip["level"], chip["value"]) == (True, "ok", "recording: 3 chunks")
    assert 0.0 <= chip["since_s"] < video_health.SILENT_AFTER_S
    monkeypatch.setattr(video_health, "SILENT_AFTER_S", 0.0)  # the page's silence is over
    card, chip = monitor_chip(pi, video_study, "booth-1")
    assert (chip["ok"], chip["level"]) == (False, "degraded")
    assert chip["value"] == (
        "video consented but the booth's recording page is not open/recording: 3 chunks")
    assert chip["since_s"] >= 0.0
    # Amber only: the booth's problems are its alarms (the absent phone), not the video.
    assert not [p for p in card["problems"] if p.startswith("Participant video")]
    assert "Phone: not connected during the session" in card["problems"]


def test_the_monitor_greys_a_declined_video_and_has_no_chip_for_a_study_without(
    pi: StaffApi, video_study: int, running: RunSession
) -> None:
    running(video=False)
    _, declined = monitor_chip(pi, video_study, "booth-1")
    assert declined is not None
    assert (declined["ok"], declined["level"], declined["value"]) == (
        None, "unknown", "not filmed: no consent")  # fmt: skip
    plain = study_with_plan(pi, participants=2)
    WizardBot.create(pi, plain, booth="booth-2").start()
    _, chip = monitor_chip(pi, plain, "booth-2")
    assert chip is None
