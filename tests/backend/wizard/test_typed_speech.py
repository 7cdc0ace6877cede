"""Speech fallback through the real HTTP API (both databases): the typed sentence becomes a
WAV in the actor's espeak-ng voice with a lip-sync curve, served only with its key, logged as
a play and as a deviation, exported; bad input and a finished session are refused readably.
No worker runs here, so the play is logged as not sent (the browser test has a worker)."""

from __future__ import annotations

import csv
import io
import random
import shutil
import wave
import zipfile

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from chameleons.backend.wizard import typed_speech
from tests.support.bots import ApiError, WizardBot, run_session, staff_api, study_with_plan

pytestmark = pytest.mark.skipif(
    shutil.which("espeak-ng") is None, reason="espeak-ng is not installed (.ci/run installs it)"
)


def test_a_typed_sentence_becomes_audio_and_a_logged_deviation(
    client: TestClient, engine: Engine
) -> None:
    pi = staff_api(client, engine, "pi")
    study_id = study_with_plan(pi, participants=3)
    wizard = WizardBot.create(pi, study_id)
    wizard.start()
    say = f"/api/wizard/sessions/{wizard.session_id}/prompts/say"
    result = pi.post(say, {"text": "  The road is   about seventy miles away. "})
    assert result["text"] == "The road is about seventy miles away."
    assert result["sent"] is False  # no worker in this test
    events = wizard.staff.get(f"/api/sessions/{wizard.session_id}/events?limit=5000")
    played = next(e for e in events if e["kind"] == "prompt.played")
    typed = next(e for e in events if e["kind"] == "wizard.typed_speech")
    assert played["payload"]["typed"] is True
    assert typed["payload"]["play_event_id"] == played["id"]
    assert typed["payload"]["actor"] == played["payload"]["actor"]
    assert played["payload"]["duration"] > 0.5

    media = typed_speech.media_url(client.app.state, played["payload"]["audio_digest"])  # type: ignore[attr-defined]
    media = media.removeprefix(client.app.state.settings.effective_public_url)  # type: ignore[attr-defined]
    assert client.get(media.split("?")[0] + "?key=wrong").status_code == 403
    audio = client.get(media)
    assert audio.status_code == 200
    assert audio.headers["content-type"] == "audio/wav"
    with wave.open(io.BytesIO(audio.content)) as wav:
        assert wav.getnframes() / wav.getframerate() == pytest.approx(
            played["payload"]["duration"], abs=0.01
        )
    curve = client.get(media.replace(".wav", ".csv"))
    rows = list(csv.DictReader(io.StringIO(curve.text)))
    assert rows[0].keys() == {"time", "jawOpen"}
    assert max(float(r["jawOpen"]) for r in rows) > 0.3  # the mouth moves while it speaks

    bundle = zipfile.ZipFile(io.BytesIO(
        client.get("/api/pi/export.zip", params={"study": study_id}).content))  # fmt: skip
    exported = [r for r in csv.DictReader(io.StringIO(bundle.read("events.csv").decode()))
                if r["kind"] == "wizard.typed_speech"]  # fmt: skip
    assert len(exported) == 1
    assert "seventy miles" in str(exported[0])
    detail = client.get(f"/pi/sessions/{wizard.session_id}").text  # counted as a deviation
    assert 'data-flag="typed_speech"' in detail
    assert "the robot said a typed sentence" in detail


def test_empty_text_and_a_finished_session_are_refused(client: TestClient, engine: Engine) -> None:
    pi = staff_api(client, engine, "pi")
    study_id = study_with_plan(pi, participants=3)
    done = run_session(pi, client, study_id, random.Random(2))
    with pytest.raises(ApiError) as refused:
        pi.post(f"/api/wizard/sessions/{done.session_id}/prompts/say", {"text": "Hello."})
    assert refused.value.status == 409
    assert "nothing more is played" in str(refused.value.detail)
    wizard = WizardBot.create(pi, study_id)
    with pytest.raises(ApiError) as empty:
        pi.post(f"/api/wizard/sessions/{wizard.session_id}/prompts/say", {"text": "   "})
    assert empty.value.status == 422
    assert "Type what the robot should say first." in str(empty.value.detail)
