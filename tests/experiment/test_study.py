from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from chameleons.experiment.study import (
    StudyError,
    load_default_study,
    load_study,
    study_from_config,
)
from tests.experiment.study_files import default_document, four_condition_document, write_study

LUNAR = [
    "oxygen",
    "water",
    "stellar_map",
    "food_concentrate",
    "fm_transceiver",
    "nylon_rope",
    "first_aid_kit",
    "parachute_silk",
    "life_raft",
    "signal_flares",
    "pistols",
    "dehydrated_milk",
    "heating_unit",
    "magnetic_compass",
    "matches",
]
DESERT = [
    "cosmetic_mirror",
    "topcoat",
    "water",
    "flashlight",
    "parachute",
    "jackknife",
    "plastic_raincoat",
    "pistol",
    "sunglasses",
    "compress_kit",
    "magnetic_compass",
    "air_map",
    "edible_animals_book",
    "vodka",
    "salt_tablets",
]


def problems_of(path: Path) -> list[str]:
    with pytest.raises(StudyError) as caught:
        load_study(path)
    return caught.value.problems


def test_default_study_has_the_papers_design() -> None:
    study = load_default_study()
    assert study.id == "mechanical-chameleons"
    assert study.condition_ids == ("still", "natural", "copy")
    assert study.task("lunar").expert_order == tuple(LUNAR)
    assert study.task("desert").expert_order == tuple(DESERT)
    assert all(item.description for task in study.tasks for item in task.items)
    assert [a.id for a in study.actors] == ["m1", "m2", "f1", "f2"]
    assert [a.gender for a in study.actors] == ["male", "male", "female", "female"]
    assert [f.id for f in study.faces] == ["face-1", "face-2", "face-3", "face-4"]
    assert len(study.robot_names) >= 8
    assert study.suggestions_per_interaction == 3


def test_default_item_sets_are_the_middle_ten_split_in_halves() -> None:
    study = load_default_study()
    assert study.scenario("lunar", "better").items == tuple(LUNAR[2:7])
    assert study.scenario("lunar", "worse").items == tuple(LUNAR[7:12])
    assert study.scenario("desert", "worse").items == tuple(DESERT[7:12])
    assert [s.id for s in study.scenarios] == [
        "lunar-better",
        "lunar-worse",
        "desert-better",
        "desert-worse",
    ]


def test_item_set_ranks_are_a_setting(tmp_path: Path) -> None:
    document = default_document()
    document["item_sets"].update(first_rank=4, last_rank=13)
    study = load_study(write_study(tmp_path, document))
    assert study.scenario("lunar", "better").items == tuple(LUNAR[3:8])
    assert study.scenario("desert", "worse").items == tuple(DESERT[8:13])


def test_default_questionnaires() -> None:
    study = load_default_study()
    sizes = {q.id: len(q.numeric_items) for q in study.questionnaires_for("interaction")}
    assert sizes == {"credibility": 12, "likeability": 10, "trust": 6, "experience": 0}
    credibility = study.questionnaire("credibility")
    assert credibility.version == "rau2009-v1"
    assert credibility.points == 7
    assert any(item.reverse for item in credibility.items)
    assert all(item.left and item.right for item in credibility.items)
    experience = study.questionnaire("experience").items
    assert [(q.id, q.type, q.identifying) for q in experience] == [("experience", "text", True)]
    assert [q.id for q in study.questionnaire("final").items] == [
        "differences", "comments", "noticed_imitation", "imitating_robot"
    ]  # fmt: skip
    assert [q.id for q in study.questionnaires_for("before")] == ["demographics"]
    assert study.measures == ("accepted", "credibility", "likeability", "trust")


def test_duplicate_expert_rank_is_reported_with_its_place(tmp_path: Path) -> None:
    document = default_document()
    document["tasks"]["lunar"]["items"][3]["expert_rank"] = 3
    problems = problems_of(write_study(tmp_path, document))
    assert "tasks.lunar.items[3]: expert rank 3 used twice" in problems
    assert "tasks.lunar.items: expert ranks must be 1..15; missing [4]" in problems


def test_every_problem_is_reported_at_once(tmp_path: Path) -> None:
    document = default_document()
    document["conditions"]["copy"]["colour"] = "green"
    del document["actors"]["f2"]["voice"]
    document["actors"]["f1"]["voice"]["pitch"] = 500
    document["item_sets"]["last_rank"] = 11
    document["tasks"]["desert"]["items"][0]["id"] = "Cosmetic Mirror"
    document["questionnaires"]["trust"]["items"][2]["type"] = "slider"
    document["robot_names"] = ["Nova", "Nova"]
    problems = problems_of(write_study(tmp_path, document))
    expected = [
        "conditions.copy.colour: unknown key",
        "actors.f2.voice: is missing",
        "actors.f1.voice.pitch: must be in 0..99, got 500",
        "item_sets: ranks 3..11 (9) do not split into 2 sets",
        "tasks.desert.items[0].id: id 'Cosmetic Mirror' must be snake_case",
        "questionnaires.trust.items[2].type: must be one of",
        "robot_names[1]: name 'Nova' listed twice",
        "robot_names: has 1, a session of 3 interactions needs 3",
    ]
    for start in expected:
        assert any(p.startswith(start) for p in problems), (start, problems)
    assert len(problems) == len(expected)


def test_too_few_actors_and_scenarios_for_the_conditions(tmp_path: Path) -> None:
    document = four_condition_document()
    del document["actors"]["m2"]
    document["item_sets"].update(first_rank=3, last_rank=7, sets=["only"])
    document["design"]["alternate_tasks"] = False
    problems = problems_of(write_study(tmp_path, document))
    assert "actors: has 3, a session of 4 interactions needs 4" in problems
    assert "item_sets: gives 2 scenarios, a session of 4 needs 4" in problems


def test_alternating_tasks_needs_two_tasks(tmp_path: Path) -> None:
    document = default_document()
    del document["tasks"]["desert"]
    document["item_sets"]["sets"] = ["a", "b", "c", "d", "e"]
    problems = problems_of(write_study(tmp_path, document))
    assert problems == ["design.alternate_tasks: needs at least 2 tasks (or set it to false)"]


def test_duplicate_yaml_keys_are_problems(tmp_path: Path) -> None:
    path = tmp_path / "study.yaml"
    text = Path(write_study(tmp_path, default_document())).read_text("utf-8")
    path.write_text(text.replace("faces:\n", "faces:\n  face-1: {label: Again}\n", 1), "utf-8")
    problems = problems_of(path)
    assert len(problems) == 1
    assert problems[0].startswith("line ")
    assert "duplicate key 'face-1'" in problems[0]


def test_unreadable_and_invalid_files(tmp_path: Path) -> None:
    assert problems_of(tmp_path / "missing.yaml")[0].startswith("cannot read the file")
    broken = tmp_path / "broken.yaml"
    broken.write_text("id: [unclosed\n", "utf-8")
    assert problems_of(broken)[0].startswith("not valid YAML")
    empty = tmp_path / "empty.yaml"
    empty.write_text("", "utf-8")
    assert problems_of(empty) == ["(top level): must be a mapping, got nothing"]


def test_study_error_message_lists_problems_with_file_and_line(tmp_path: Path) -> None:
    document = default_document()
    document["name"] = ""
    path = write_study(tmp_path, document)
    line = next(n for n, text in enumerate(path.read_text("utf-8").splitlines(), 1)
                if text.startswith("name:"))  # fmt: skip
    with pytest.raises(StudyError) as caught:
        load_study(path)
    assert str(caught.value).startswith(f"{path} has 1 problem(s):\n  - {path}:{line}: name: ")
    assert caught.value.problems == ["name: must be a non-empty text, got text ''"]
    assert caught.value.located == [f"{path}:{line}: name: must be a non-empty text, got text ''"]


def test_hash_is_stable_and_tracks_content(tmp_path: Path) -> None:
    study = load_default_study()
    assert study.content_hash == load_default_study().content_hash
    assert len(study.content_hash) == 64
    # Formatting and comments do not matter, content does.
    reformatted = load_study(write_study(tmp_path, default_document(), "reformatted.yaml"))
    assert reformatted.content_hash == study.content_hash
    document = default_document()
    document["tasks"]["lunar"]["items"][0]["description"] = "Breathing first."
    changed = load_study(write_study(tmp_path, document, "changed.yaml"))
    assert changed.content_hash != study.content_hash


def test_condition_order_is_content(tmp_path: Path) -> None:
    document = default_document()
    document["conditions"] = dict(reversed(list(document["conditions"].items())))
    reordered = load_study(write_study(tmp_path, document))
    assert reordered.content_hash != load_default_study().content_hash


def _shuffle_keys(value: Any) -> Any:
    """Reverse every mapping's key order, as a JSON database column may reorder keys."""
    if isinstance(value, dict):
        return {k: _shuffle_keys(value[k]) for k in reversed(list(value))}
    if isinstance(value, list):
        return [_shuffle_keys(v) for v in value]
    return value


def test_config_snapshot_rebuilds_the_same_study() -> None:
    study = load_default_study()
    stored = json.loads(json.dumps(study.config))
    rebuilt = study_from_config(_shuffle_keys(stored))
    assert rebuilt == study
    assert rebuilt.content_hash == study.content_hash
    assert rebuilt.config == study.config


def test_broken_snapshot_reports_places() -> None:
    config = json.loads(json.dumps(load_default_study().config))
    config["tasks"][0]["items"][2]["expert_rank"] = "three"
    with pytest.raises(StudyError) as caught:
        study_from_config(config)
    assert caught.value.problems[0].startswith("tasks.lunar.items[2].expert_rank: must be a whole")


def test_a_lab_can_write_a_four_condition_study(tmp_path: Path) -> None:
    study = load_study(write_study(tmp_path, four_condition_document()))
    assert study.interactions_per_session == 4
    assert study.condition_ids[-1] == "copy_fast"
    assert (study.condition("copy_fast").behaviour, study.condition("copy_fast").params) == (
        "copy", {"delay": 1.0},
    )  # fmt: skip
