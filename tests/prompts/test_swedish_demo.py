"""The committed Swedish demo catalogue runs the whole study: every prompt group of the
English demo, with the same stage, task, item and robot name, in Swedish, voiced by its own
recordings and curves (issue 28: a Swedish session had no suggestion phrasings)."""

from __future__ import annotations

import csv

import pytest

from chameleons.prompts import Catalogue, load_catalogue
from tests.prompts.test_demo_catalogue import (
    ACTORS,
    KNOWN_ITEMS,
    PROMPTS,
    ROBOT_NAMES,
    _load_writer,
)

SWEDISH = PROMPTS / "sv"
MAX_AUDIO_BYTES = 20 * 1024 * 1024  # as the English demo's (tests/backend/display)


@pytest.fixture(scope="module")
def pairs() -> dict[str, tuple[Catalogue, Catalogue]]:
    """actor -> (English, Swedish), each checked against the default study's items."""
    return {
        actor: tuple(  # type: ignore[misc]
            load_catalogue(folder / actor, KNOWN_ITEMS, robot_names=ROBOT_NAMES)
            for folder in (PROMPTS, SWEDISH)
        )
        for actor in ACTORS
    }


@pytest.mark.parametrize("actor", ACTORS)
def test_every_english_prompt_has_its_swedish_twin(
    pairs: dict[str, tuple[Catalogue, Catalogue]], actor: str
) -> None:
    english, swedish = pairs[actor]
    assert swedish.profile.language == "sv"
    assert str(swedish.profile.voice["espeak_voice"]).startswith("sv+")
    assert [p.id for p in swedish.prompts] == [p.id for p in english.prompts]
    for theirs in english.prompts:
        ours = swedish.by_id(theirs.id)
        same = ("stage", "group", "task", "item", "other_item", "robot_name")
        assert [getattr(ours, k) for k in same] == [getattr(theirs, k) for k in same]
        if ours.text != "Hmm.":  # the one sound both languages make alike
            assert ours.text != theirs.text, ours.id
        assert not set("{}") & set(ours.text), ours.id
        assert ours.text[0].isupper(), ours.id
        assert ours.text[-1] in ".?!", ours.id
        if ours.robot_name:
            assert ours.robot_name in ours.text


@pytest.mark.parametrize("actor", ACTORS)
def test_every_swedish_prompt_is_voiced_by_its_own_recording(
    pairs: dict[str, tuple[Catalogue, Catalogue]], actor: str
) -> None:
    english, swedish = pairs[actor]
    for prompt in swedish.prompts:
        audio, curves = swedish.audio_file(prompt), swedish.lipsync_file(prompt)
        assert audio is not None, prompt.id
        assert curves is not None, prompt.id
        assert audio.is_relative_to(SWEDISH / actor)
        assert curves.is_file()
        twin = english.audio_file(english.by_id(prompt.id))
        assert twin is not None
        assert audio.read_bytes() != twin.read_bytes(), prompt.id


def test_the_swedish_audio_stays_compact() -> None:
    total = sum(path.stat().st_size for path in SWEDISH.glob("*/audio/*.mp3"))
    english = sum(path.stat().st_size for path in PROMPTS.glob("*/audio/*.mp3"))
    assert total < MAX_AUDIO_BYTES
    assert total < 1.3 * english


def test_committed_swedish_files_match_the_generator() -> None:
    rendered = _load_writer().render_catalogue(PROMPTS, "sv")
    assert len(rendered) == 2 * len(ACTORS)  # a manifest and a profile per actor
    for path, text in rendered.items():
        committed = path.read_text(encoding="utf-8")
        if path.name == "actor.yaml":
            assert committed == text, f"{path} is stale"
            continue

        def content(manifest: str) -> list[list[str]]:
            rows = csv.DictReader(manifest.splitlines())
            return [[v for k, v in row.items() if k not in ("audio", "lipsync")] for row in rows]

        assert content(committed) == content(text), (
            f"{path} is stale: run .venv/bin/python scripts/write_swedish_demo.py"
        )


def test_swedish_pronouns_follow_gender_and_number() -> None:
    item = _load_writer().Item
    fields = ("lunar", 1, "x", "n", "s", "w", "w")
    assert item(*fields, language="sv").pronouns()["it"] == "den"
    assert item(*fields, gender="ett", language="sv").pronouns()["it"] == "det"
    plural = item(*fields, plural=True, language="sv").pronouns()
    assert (plural["it"], plural["they"]) == ("dem", "de")
    assert item(*fields, plural=True).pronouns()["it"] == "them"
