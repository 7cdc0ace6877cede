"""Prompt catalogues per language: a Swedish session's console offers only the Swedish
prompts (the demo's espeak-ng subset) and lists the groups without a Swedish recording."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from types import SimpleNamespace

import pytest

from chameleons.backend.wizard.catalogues import catalogue_for, missing_in_language
from chameleons.prompts import load_catalogue
from chameleons.prompts.languages import catalogue_languages
from tests.backend.wizard.conftest import api
from tests.support.bots import StaffApi, WizardBot, study_with_plan

PROMPTS = Path(__file__).resolve().parents[3] / "prompts"


def app_state() -> SimpleNamespace:
    return SimpleNamespace(settings=SimpleNamespace(prompts_dir=str(PROMPTS), data_dir=None))


def test_the_demo_ships_a_voiced_swedish_subset_for_every_actor() -> None:
    for actor in ("m1", "m2", "f1", "f2"):
        english = load_catalogue(PROMPTS / actor)
        swedish = load_catalogue(PROMPTS / "sv" / actor)
        assert swedish.profile.language == "sv"
        assert str(swedish.profile.voice["espeak_voice"]).startswith("sv+")
        assert catalogue_languages(PROMPTS, english) == ["en", "sv"]
        assert len(swedish) >= 15
        for prompt in swedish.prompts:  # recorded, with lip-sync, in a group English has
            audio = swedish.audio_file(prompt)
            assert audio is not None
            assert audio.stat().st_size > 1000
            assert swedish.lipsync_file(prompt) is not None
            english.group(prompt.group)


def test_a_language_gets_only_its_prompts_and_the_rest_is_listed() -> None:
    state = app_state()
    english = catalogue_for(state, "f1")
    swedish = catalogue_for(state, "f1", "sv")
    assert catalogue_for(state, "f1", "en") is english
    assert {p.text for p in swedish.prompts}.isdisjoint({p.text for p in english.prompts})
    assert swedish.group("ack_yes").prompts[0].text == "Ja, det tycker jag också."
    missing = missing_in_language(state, "f1", "sv")
    assert "ack_i_see" in missing
    assert "ack_yes" not in missing
    assert len(missing) == len(english.groups()) - len(swedish.groups())
    nothing = catalogue_for(state, "f1", "de")
    assert len(nothing) == 0
    assert missing_in_language(state, "f1", "de") == [g.name for g in english.groups()]


def test_the_console_of_a_swedish_session_offers_only_swedish_prompts(pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=2)
    wizard = WizardBot.create(pi, study_id, language="sv")
    data = wizard.staff.get(f"{api(wizard)}/prompts")
    assert data["language"] == "sv"
    swedish = load_catalogue(PROMPTS / "sv" / wizard.interaction(1)["actor"])
    offered = {b["group"] for section in data["sections"] for b in section["buttons"]}
    assert offered
    assert offered <= {g.name for g in swedish.groups()}
    assert "ack_i_see" in data["missing"]
    played = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_yes"})
    assert played["text"] == "Ja, det tycker jag också."
    refused = wizard.staff.http.post(
        f"{api(wizard)}/prompts/play",
        json={"group": "ack_i_see"},
        headers={"X-CSRF-Token": wizard.staff.csrf},
    )
    assert refused.status_code == 404
    assert refused.json()["detail"].endswith("has no prompt group 'ack_i_see' in sv.")
    english = WizardBot.create(pi, study_id)
    assert english.staff.get(f"{api(english)}/prompts")["missing"] == []


@pytest.mark.skipif(shutil.which("espeak-ng") is None, reason="espeak-ng is not installed")
def test_typed_speech_of_a_swedish_session_uses_the_actors_swedish_voice(pi: StaffApi) -> None:
    wizard = WizardBot.create(pi, study_with_plan(pi, participants=2), language="sv")
    wizard.start()
    text = "Vi tar det lugnt."
    pi.post(f"{api(wizard)}/prompts/say", {"text": text})
    events = wizard.staff.get(f"/api/sessions/{wizard.session_id}/events?limit=500")
    played = next(e for e in events if e["kind"] == "prompt.played")
    voice = load_catalogue(PROMPTS / "sv" / wizard.interaction(1)["actor"]).profile.voice
    key = json.dumps({"voice": dict(voice), "text": text}, sort_keys=True)
    assert played["payload"]["audio_digest"] == hashlib.sha256(key.encode()).hexdigest()[:24]
