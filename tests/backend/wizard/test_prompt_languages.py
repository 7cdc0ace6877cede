"""Prompt catalogues per language: a Swedish session's console offers only the Swedish
prompts (the demo's complete espeak-ng catalogue) and lists the groups a language lacks."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from types import SimpleNamespace

import pytest

from chameleons.backend.wizard.catalogues import catalogue_for, is_loaded, missing_in_language
from chameleons.prompts import load_catalogue
from chameleons.prompts.languages import catalogue_languages
from tests.backend.wizard.conftest import api
from tests.support.bots import StaffApi, WizardBot, study_with_plan

PROMPTS = Path(__file__).resolve().parents[3] / "prompts"


def app_state(root: Path = PROMPTS) -> SimpleNamespace:
    return SimpleNamespace(settings=SimpleNamespace(prompts_dir=str(root), data_dir=None))


def test_the_demo_ships_a_complete_voiced_swedish_catalogue_for_every_actor() -> None:
    state = app_state()
    for actor in ("m1", "m2", "f1", "f2"):
        english = load_catalogue(PROMPTS / actor)
        swedish = load_catalogue(PROMPTS / "sv" / actor)
        assert swedish.profile.language == "sv"
        assert catalogue_languages(PROMPTS, english) == ["en", "sv"]
        assert len(swedish) == len(english)
        assert all(p.audio is not None and p.lipsync is not None for p in swedish.prompts)
        assert missing_in_language(state, actor, "sv") == []


def partial_language(tmp_path: Path) -> Path:
    """A prompts folder with the demo's f1 and only three of its groups in German."""
    root = tmp_path / "prompts"
    (root / "de" / "f1").mkdir(parents=True)
    (root / "f1").symlink_to(PROMPTS / "f1", target_is_directory=True)
    (root / "de" / "f1" / "manifest.csv").write_text(
        "id,stage,group,text\n"
        "ack_yes_1,acknowledgement,ack_yes,Ja.\n"
        'ack_yes_2,acknowledgement,ack_yes,"Ja, genau."\n'
        "ack_no,acknowledgement,ack_no,Nein.\n"
        "closing,closing,closing,Danke.\n",
        encoding="utf-8",
    )
    return root


def test_a_language_gets_only_its_prompts_and_the_rest_is_listed(tmp_path: Path) -> None:
    state = app_state(partial_language(tmp_path))
    english = catalogue_for(state, "f1")
    german = catalogue_for(state, "f1", "de")
    assert catalogue_for(state, "f1", "en") is english
    assert german.language_folder == "de"
    assert [g.name for g in german.groups()] == ["ack_yes", "ack_no", "closing"]
    missing = missing_in_language(state, "f1", "de")
    assert "ack_i_see" in missing
    assert "ack_yes" not in missing
    assert len(missing) == len(english.groups()) - len(german.groups())
    nothing = catalogue_for(state, "f1", "fi")
    assert len(nothing) == 0
    assert missing_in_language(state, "f1", "fi") == [g.name for g in english.groups()]


def test_the_console_of_a_swedish_session_offers_only_swedish_prompts(pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=2)
    wizard = WizardBot.create(pi, study_id, language="sv")
    data = wizard.staff.get(f"{api(wizard)}/prompts")
    assert data["language"] == "sv"
    swedish = load_catalogue(PROMPTS / "sv" / wizard.interaction(1)["actor"])
    offered = {b["group"] for section in data["sections"] for b in section["buttons"]}
    assert offered
    assert offered <= {g.name for g in swedish.groups()}
    assert data["missing"] == []
    played = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_yes"})
    assert played["text"] in {p.text for p in swedish.group("ack_yes").prompts}
    refused = wizard.staff.http.post(
        f"{api(wizard)}/prompts/play",
        json={"group": "ack_nonsense"},
        headers={"X-CSRF-Token": wizard.staff.csrf},
    )
    assert refused.status_code == 404
    assert refused.json()["detail"].endswith("has no prompt group 'ack_nonsense' in sv.")
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


def test_is_loaded_says_when_a_catalogue_answers_from_memory(tmp_path: Path) -> None:
    """The event loop builds a console's state itself only when its prompts need no file
    read (issue 34): ``is_loaded`` is false until the catalogue of that language is loaded."""
    state = app_state(partial_language(tmp_path))
    assert not is_loaded(state, "f1")
    english = catalogue_for(state, "f1")
    assert is_loaded(state, "f1")
    assert is_loaded(state, "f1", english.profile.language)  # the base catalogue's language
    assert not is_loaded(state, "f1", "de")
    catalogue_for(state, "f1", "de")
    assert is_loaded(state, "f1", "de")
    assert not is_loaded(state, "m1")
