"""The speech fallback on a Furhat, end to end through a real bridge and worker: the typed
sentence goes to the robot's own TTS in the actor's Furhat voice from the study (no WAV is
synthesised), the robot's speech start and end are logged like a prompt's, and the
sentence is logged as a deviation with its text. The robot is the project's Furhat peer."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from chameleons.backend.bridge import Bridge
from chameleons.backend.wizard import typed_speech
from tests.backend.booth.conftest import (
    new_session,
    running_worker,
    timeline,
    until,
    wait_for_event,
    worker_config,
)
from tests.experiment.study_files import default_document, study_yaml
from tests.support.bots import StaffApi, study_with_plan
from tests.worker.furhat_peer import FurhatPeer

VOICES = {"m1": "Matthew-Neural", "m2": "Brian", "f1": "Joanna-Neural", "f2": "Amy"}
SENTENCE = "The road is about seventy miles away."


def _study_with_furhat_voices(pi: StaffApi) -> int:
    document = default_document()
    for actor, voice in VOICES.items():
        document["actors"][actor]["voice"]["furhat"] = voice
    return study_with_plan(pi, participants=3, yaml=study_yaml(document))


@pytest.mark.usefixtures("flow")
def test_typed_speech_on_a_furhat_is_its_own_tts_in_the_actors_voice_and_a_deviation(
    pi: StaffApi, bridge: Bridge, tmp_path: Path, client: TestClient
) -> None:
    wizard, _ = new_session(pi, _study_with_furhat_voices(pi))
    wizard.start()
    with FurhatPeer(speech_seconds=0.4, voices=tuple(VOICES.values())) as robot:
        config = worker_config(bridge, tmp_path, driver="furhat", robot_url=robot.url)
        with running_worker(bridge, config):
            wait_for_event(wizard, "robot.connected")
            answer = pi.post(f"/api/wizard/sessions/{wizard.session_id}/prompts/say",
                             {"text": f"  {SENTENCE}  "})  # fmt: skip
            end = wait_for_event(wizard, "prompt.speech_end")
            said = until(lambda: robot.said, what="the robot saying the sentence")
        wait_for_event(wizard, "robot.disconnected")  # no write left for the teardown
    events = timeline(wizard)
    played = next(e for e in events if e["kind"] == "prompt.played")
    typed = next(e for e in events if e["kind"] == "wizard.typed_speech")
    start = next(e for e in events if e["kind"] == "prompt.speech_start")
    actor = played["payload"]["actor"]
    assert answer["sent"] is True
    assert said == [(SENTENCE, VOICES[actor])]
    assert played["payload"]["robot_tts"] is True
    assert played["payload"]["voice"] == VOICES[actor]
    assert played["payload"]["has_audio"] is False
    assert "audio_digest" not in played["payload"]
    assert typed["payload"]["text"] == SENTENCE
    assert typed["payload"]["play_event_id"] == played["id"]
    assert start["payload"]["play_event_id"] == end["payload"]["play_event_id"] == played["id"]
    assert end["payload"]["outcome"] == "played"
    assert not robot.of_type("request.speak.audio")
    settings = client.app.state.settings  # type: ignore[attr-defined]
    assert not typed_speech.folder(settings).exists()  # nothing synthesised on the server
    detail = client.get(f"/pi/sessions/{wizard.session_id}").text  # counted as a deviation
    assert 'data-flag="typed_speech"' in detail
    assert f'the robot said a typed sentence: "{SENTENCE}"' in detail.replace("&#34;", '"')
