"""Loading and validating manifests written to tmp_path: every problem names file and line."""

from __future__ import annotations

import random
import wave
from pathlib import Path

import pytest

from chameleons.prompts import (
    MANIFEST_COLUMNS,
    CatalogueError,
    Stage,
    SuggestionKind,
    load_catalogue,
    load_catalogues,
    pick_variant,
    write_manifest,
)

KNOWN_ITEMS = {"lunar": {"oxygen", "water", "stellar_map"}, "desert": {"water", "topcoat"}}
HEADER = ",".join(MANIFEST_COLUMNS)
GOOD_ROWS = [
    "ack_yes_1,acknowledgement,ack_yes,Yes.,,,,,,",
    'ack_yes_2,acknowledgement,ack_yes,"Yes, indeed.",,,,,,',
    'intro_nova,intro,intro_nova,"Hello, I\'m Nova.",,,,Nova,,',
    "lunar_water_describe,item_description,,Water keeps us alive.,lunar,water,,,,",
    "lunar_water_move_up,suggestion,lunar_water_move_up,Move the water up?,lunar,water,,,,",
    "lunar_water_make_first,suggestion,lunar_water_make_first,Water first?,lunar,water,,,,",
    "lunar_water_above_oxygen,suggestion,lunar_water_above_oxygen,"
    "Water above oxygen?,lunar,water,oxygen,,,",
    "desert_water_move_up,suggestion,,Move the water up?,desert,water,,,,",
]
DOWN_ROWS = [
    "lunar_oxygen_move_down,suggestion,,Move the oxygen down?,lunar,oxygen,,,,",
    "lunar_oxygen_make_last,suggestion,,Oxygen last?,lunar,oxygen,,,,",
    "lunar_oxygen_below_water,suggestion,,Oxygen below the water?,lunar,oxygen,water,,,",
]


def write_actor(root: Path, lines: list[str], actor: str = "m1", header: str = HEADER) -> Path:
    actor_dir = root / actor
    actor_dir.mkdir(parents=True)
    (actor_dir / "manifest.csv").write_text("\n".join([header, *lines]) + "\n", encoding="utf-8")
    return actor_dir


def problems_of(actor_dir: Path, **kwargs: object) -> list[str]:
    with pytest.raises(CatalogueError) as caught:
        load_catalogue(actor_dir, **kwargs)  # type: ignore[arg-type]
    return caught.value.problems


def test_good_manifest_loads_with_lookups(tmp_path: Path) -> None:
    catalogue = load_catalogue(write_actor(tmp_path, GOOD_ROWS), KNOWN_ITEMS)

    assert catalogue.actor == "m1"
    assert len(catalogue) == len(GOOD_ROWS)
    assert catalogue.by_id("ack_yes_2").text == "Yes, indeed."
    assert [p.id for p in catalogue.group("ack_yes").prompts] == ["ack_yes_1", "ack_yes_2"]
    assert catalogue.by_stage(Stage.INTRO)[0].robot_name == "Nova"
    # An empty group cell makes a one-prompt group named after the id.
    assert catalogue.group("lunar_water_describe").stage is Stage.ITEM_DESCRIPTION
    assert {p.id for p in catalogue.for_item("desert", "water")} == {"desert_water_move_up"}
    prompt = catalogue.by_id("lunar_water_describe")
    assert prompt.item_ref == "lunar:water"
    assert prompt.audio is None
    assert catalogue.audio_file(prompt) is None
    assert prompt.estimated_duration == pytest.approx(4 / 2.6, abs=0.01)
    assert catalogue.duration(prompt) == prompt.estimated_duration


def test_suggestion_prompts_in_preference_order(tmp_path: Path) -> None:
    catalogue = load_catalogue(write_actor(tmp_path, GOOD_ROWS))

    to_first = catalogue.suggestion_prompts("lunar", "water", 1, "oxygen")
    assert [g.name for g in to_first] == [
        "lunar_water_above_oxygen",
        "lunar_water_make_first",
        "lunar_water_move_up",
    ]
    assert [g.suggestion_kind for g in to_first] == list(SuggestionKind)[:3]
    # Not to the top, and a pair without its own prompt: only the generic one fits.
    assert [g.name for g in catalogue.suggestion_prompts("lunar", "water", 2, "stellar_map")] == [
        "lunar_water_move_up"
    ]
    assert catalogue.suggestion_prompts("lunar", "oxygen", 1) == []


def test_suggestion_prompts_for_a_move_down_in_preference_order(tmp_path: Path) -> None:
    catalogue = load_catalogue(write_actor(tmp_path, GOOD_ROWS + DOWN_ROWS))
    assert catalogue.suggestion_prompts("lunar", "oxygen", 1) == []  # no move up for oxygen

    to_last = catalogue.suggestion_prompts("lunar", "oxygen", 3, "water", down=True, last_rank=3)
    assert [g.name for g in to_last] == [
        "lunar_oxygen_below_water",
        "lunar_oxygen_make_last",
        "lunar_oxygen_move_down",
    ]
    assert [g.suggestion_kind for g in to_last] == list(SuggestionKind)[3:]
    assert all(g.suggestion_kind is not None and g.suggestion_kind.down for g in to_last)
    # Not to the bottom, and no pair prompt: only the generic move down; never a move up.
    middle = catalogue.suggestion_prompts("lunar", "oxygen", 2, "stellar_map", down=True,
                                          last_rank=3)  # fmt: skip
    assert [g.name for g in middle] == ["lunar_oxygen_move_down"]
    assert catalogue.suggestion_prompts("lunar", "water", 3, down=True, last_rank=3) == []


def test_pick_variant_never_repeats_the_last_one(tmp_path: Path) -> None:
    group = load_catalogue(write_actor(tmp_path, GOOD_ROWS)).group("ack_yes")
    rng = random.Random(7)

    picks = [pick_variant(group, "ack_yes_1", rng).id for _ in range(20)]

    assert set(picks) == {"ack_yes_2"}
    single = load_catalogue(tmp_path / "m1").group("intro_nova")
    assert pick_variant(single, "intro_nova", rng).id == "intro_nova"


def test_audio_and_lipsync_files_resolve_and_wav_gives_duration(tmp_path: Path) -> None:
    actor_dir = write_actor(
        tmp_path, ["hello,intro,,Hello there.,,,,,audio/hello.wav,lipsync/hello.csv"]
    )
    (actor_dir / "audio").mkdir()
    with wave.open(str(actor_dir / "audio" / "hello.wav"), "wb") as writer:
        writer.setnchannels(1)
        writer.setsampwidth(2)
        writer.setframerate(16000)
        writer.writeframes(b"\x00\x00" * 24000)
    (actor_dir / "lipsync").mkdir()
    (actor_dir / "lipsync" / "hello.csv").write_text("time,jawOpen\n0,0\n", encoding="utf-8")

    catalogue = load_catalogue(actor_dir)
    prompt = catalogue.by_id("hello")

    assert catalogue.audio_file(prompt) == actor_dir / "audio" / "hello.wav"
    assert catalogue.lipsync_file(prompt) == actor_dir / "lipsync" / "hello.csv"
    assert catalogue.duration(prompt) == pytest.approx(1.5)


def test_quoted_multiline_text_and_excel_bom(tmp_path: Path) -> None:
    actor_dir = tmp_path / "f1"
    actor_dir.mkdir()
    content = (
        f'{HEADER}\nlong,closing,,"Thank you.\nPlease take the phone.",,,,,,\nx,bogus,,Hi,,,,,,\n'
    )
    (actor_dir / "manifest.csv").write_bytes(b"\xef\xbb\xbf" + content.encode())

    problems = problems_of(actor_dir)

    # The quoted cell spans lines 2-3, so the broken row starts on line 4.
    assert len(problems) == 1
    assert problems[0].startswith(f"{actor_dir / 'manifest.csv'}:4: unknown stage 'bogus'")


@pytest.mark.parametrize(
    ("bad_row", "expected"),
    [
        (
            "ack_yes_1,acknowledgement,ack_yes,Again yes.,,,,,,",
            "duplicate id 'ack_yes_1' (first on line 2)",
        ),
        ("oops,shouting,,Hey!,,,,,,", "unknown stage 'shouting'"),
        ("x1,item_description,,It floats.,lunar,life_raft,,,,", "unknown item 'lunar:life_raft'"),
        ("x2,scenario,,The jungle.,jungle,,,,,", "unknown task 'jungle'"),
        ("x3,suggestion,,Above?,lunar,water,parachute,,,", "unknown other_item 'lunar:parachute'"),
        ("x4,intro,,Hi.,,,,,audio/x4.mp3,", "audio file 'audio/x4.mp3' not found"),
        ("x5,intro,,Hi.,,,,,,lipsync/x5.csv", "lipsync file 'lipsync/x5.csv' not found"),
        ("x6,intro,,Hi.,,,,,../../etc/passwd,", "must be relative to the actor folder"),
        ("x7,closing,,,,,,,,", "empty text"),
        ("x8,closing,,   ,,,,,,", "empty text"),
        (",closing,,Bye.,,,,,,", "empty id"),
        ("x9,suggestion,,Move it up.,,,,,,", "stage 'suggestion' needs a task and an item"),
        (
            "x10,acknowledgement,ack_yes,Yes!,lunar,water,,,,",
            "group 'ack_yes' differs from its first prompt (line 2) in task, item",
        ),
        ("x11,intro,,Hi.,,,,Bob,,", "unknown robot_name 'Bob'"),
        ("x12,closing,,Bye.,,,,,,,extra", "cell(s) beyond the header"),
    ],
)
def test_each_broken_row_is_reported_at_its_line(
    tmp_path: Path, bad_row: str, expected: str
) -> None:
    # Rows 2..9 are good; the broken one lands on line 10.
    actor_dir = write_actor(tmp_path, [*GOOD_ROWS, bad_row])

    problems = problems_of(actor_dir, known_items=KNOWN_ITEMS, robot_names={"Nova"})

    assert len(problems) == 1, problems
    assert problems[0].startswith(f"{actor_dir / 'manifest.csv'}:10: ")
    assert expected in problems[0]


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        # The unclosed quote opened on line 2 swallows the rest of the file.
        (b'a,intro,,"Hello there,,,,,,\nb,intro,,Bye,,,,,,\n', ":2: broken quoting"),
        (b'a,intro,,Hi,,,,,,\nb,intro,,"Hi" you,,,,,,\n', ":3: broken quoting"),
        (b"a,intro,,\xff\xfe,,,,,,\n", ": cannot read manifest: 'utf-8' codec"),
    ],
)
def test_unreadable_manifest_is_reported_not_raised(
    tmp_path: Path, content: bytes, expected: str
) -> None:
    actor_dir = tmp_path / "m1"
    actor_dir.mkdir()
    (actor_dir / "manifest.csv").write_bytes(HEADER.encode() + b"\n" + content)

    problems = problems_of(actor_dir)

    assert len(problems) == 1
    assert problems[0].startswith(f"{actor_dir / 'manifest.csv'}{expected}")


def test_missing_required_column_is_reported_on_the_header_line(tmp_path: Path) -> None:
    header = "id,group,text,task,item"
    actor_dir = write_actor(tmp_path, ["a,,Hello,,"], header=header)

    problems = problems_of(actor_dir)

    assert problems == [f"{actor_dir / 'manifest.csv'}:1: missing required column 'stage'"]


def test_all_problems_are_collected_in_one_pass(tmp_path: Path) -> None:
    actor_dir = write_actor(
        tmp_path, ["a,intro,,Hi.,,,,,,", "a,intro,,Hi again.,,,,,,", "b,nope,,,,,,,,"]
    )

    with pytest.raises(CatalogueError) as caught:
        load_catalogue(actor_dir)
    error_text = str(caught.value)

    manifest = actor_dir / "manifest.csv"
    assert f"{manifest}:3: duplicate id 'a' (first on line 2)" in error_text
    assert f"{manifest}:4: unknown stage 'nope'" in error_text
    assert f"{manifest}:4: empty text" in error_text
    assert error_text.startswith("3 problems in the prompt catalogue:")


def test_actor_profile_is_read_and_checked(tmp_path: Path) -> None:
    actor_dir = write_actor(tmp_path, GOOD_ROWS)
    (actor_dir / "actor.yaml").write_text(
        "display_name: Calm voice\ngender: male\npersonality: calm\n"
        "voice: {espeak_voice: en-gb+m3, pitch: 40, speed: 150}\n",
        encoding="utf-8",
    )
    profile = load_catalogue(actor_dir).profile
    assert (profile.display_name, profile.gender, profile.voice["speed"]) == (
        "Calm voice",
        "male",
        150,
    )

    (actor_dir / "actor.yaml").write_text("gender: robot\nvoicee: {}\n", encoding="utf-8")
    problems = problems_of(actor_dir)
    assert f"{actor_dir / 'actor.yaml'}: unknown setting 'voicee'" in problems
    assert any("gender 'robot'" in p for p in problems)


def test_load_catalogues_collects_problems_of_every_actor(tmp_path: Path) -> None:
    write_actor(tmp_path, GOOD_ROWS, actor="m1")
    write_actor(tmp_path, ["z,closing,,,,,,,,"], actor="f1")
    write_actor(tmp_path, ["z,bogus,,Bye.,,,,,,"], actor="f2")
    (tmp_path / "_source").mkdir()  # not an actor: no manifest, leading underscore

    with pytest.raises(CatalogueError) as caught:
        load_catalogues(tmp_path)
    problems = caught.value.problems

    assert problems == [
        f"{tmp_path / 'f1' / 'manifest.csv'}:2: empty text",
        f"{tmp_path / 'f2' / 'manifest.csv'}:2: unknown stage 'bogus' (expected one of: "
        "intro, scenario, item_description, item_question, rank_instruction, suggestion, "
        "acknowledgement, repeat, cannot_answer, transition, closing)",
    ]
    (tmp_path / "f1" / "manifest.csv").unlink()
    (tmp_path / "f2" / "manifest.csv").unlink()
    assert list(load_catalogues(tmp_path, KNOWN_ITEMS)) == ["m1"]


def test_missing_manifest_and_empty_root(tmp_path: Path) -> None:
    (tmp_path / "m2").mkdir()
    assert problems_of(tmp_path / "m2") == [
        f"{tmp_path / 'm2' / 'manifest.csv'}: manifest not found"
    ]
    with pytest.raises(CatalogueError, match="no actor directories"):
        load_catalogues(tmp_path)


def test_write_manifest_round_trips(tmp_path: Path) -> None:
    rows: list[dict[str, str | None]] = [
        {"id": "q", "stage": "closing", "group": "closing", "text": 'Say "bye", then go.'},
        {"id": "r", "stage": "intro", "text": "Hi,\nthere.", "robot_name": "Iris", "audio": None},
    ]
    write_manifest(tmp_path / "m1" / "manifest.csv", rows)

    catalogue = load_catalogue(tmp_path / "m1")

    assert [(p.id, p.text, p.robot_name) for p in catalogue.prompts] == [
        ("q", 'Say "bye", then go.', None),
        ("r", "Hi,\nthere.", "Iris"),
    ]


def test_command_line_check_prints_problems_and_exit_code(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from chameleons.prompts.__main__ import main

    write_actor(tmp_path, GOOD_ROWS, actor="m1")
    assert main([str(tmp_path)]) == 0
    assert "m1: 8 prompts, 0 with audio" in capsys.readouterr().out

    write_actor(tmp_path, ["a,intro,,,,,,,,"], actor="m2")
    assert main([str(tmp_path / "m2")]) == 1
    assert capsys.readouterr().err.strip() == f"{tmp_path / 'm2' / 'manifest.csv'}:2: empty text"
