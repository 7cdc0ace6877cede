"""The study file's options added for study fidelity and generality (issue 13): each option
loads into the model, and each refusal names its place, with the file and line."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from chameleons.experiment.study import (
    StudyError,
    default_study_path,
    load_study,
    study_from_config,
)
from chameleons.worker.behaviours.params import Param
from tests.experiment.study_files import default_document, write_study


def refusal(tmp_path: Path, document: dict[str, Any], **kwargs: Any) -> StudyError:
    with pytest.raises(StudyError) as caught:
        load_study(write_study(tmp_path, document), **kwargs)
    return caught.value


def line_of(path: Path, text: str, after: str = "") -> int:
    """The 1-based line of the first line starting with ``text`` (after ``after``)."""
    lines = path.read_text("utf-8").splitlines()
    start = next(n for n, line in enumerate(lines) if after in line) if after else 0
    found = (n for n, line in enumerate(lines[start:], start + 1) if line.strip().startswith(text))
    return next(found)


def test_conditions_run_a_behaviour_with_checked_parameters(tmp_path: Path) -> None:
    document = default_document()
    document["conditions"] = {
        "still": {"label": "Still", "behaviour": "still"},
        "copy_fast": {"label": "Copy 1 s", "behaviour": "copy", "params": {"delay": 1.0}},
        "copy_slow": {"label": "Copy 4 s", "behaviour": "copy", "params": {"delay": 4}},
    }
    study = load_study(write_study(tmp_path, document))
    assert [(c.id, c.behaviour, c.params) for c in study.conditions] == [
        ("still", "still", {}),
        ("copy_fast", "copy", {"delay": 1.0}),
        ("copy_slow", "copy", {"delay": 4.0}),
    ]
    # The snapshot says exactly what ran, defaults included, and rebuilds the same study.
    stored = json.loads(json.dumps(study.config))
    assert stored["conditions"][1]["params"] == {"delay": 1.0}
    assert study_from_config(stored) == study


def test_defaults_of_declared_parameters_are_filled_in(tmp_path: Path) -> None:
    document = default_document()
    document["conditions"]["copy"].pop("params")
    document["conditions"]["natural"]["params"] = {"source": "yoked"}
    study = load_study(write_study(tmp_path, document))
    assert study.condition("copy").params == {"delay": 4.0}
    assert study.condition("natural").params == {
        "source": "yoked", "clip": "demo-natural", "yoked_min_seconds": 30.0, "seed": 0,
        "offset": 0.0, "loop": True,
    }  # fmt: skip


def test_a_condition_without_behaviour_runs_the_behaviour_of_its_name(tmp_path: Path) -> None:
    document = default_document()
    for body in document["conditions"].values():
        body.pop("behaviour")
    study = load_study(write_study(tmp_path, document))
    assert [c.behaviour for c in study.conditions] == ["still", "natural", "copy"]


DELAY = (
    "a number of seconds in 0..11.5 or a distribution ({uniform: [low, high]} or "
    "{normal: {mean: m, sd: s}})"
)


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"delay": 20.0}, f"conditions.copy.params.delay: must be {DELAY}, got 20.0"),
        ({"delay": "4 s"}, f"conditions.copy.params.delay: must be {DELAY}, got '4 s'"),
        ({"dealy": 4.0}, "conditions.copy.params.dealy: unknown parameter (this behaviour "
                         "takes: channels, coexpress, delay, delay_resample_s, gain, "
                         "intermittent, mirror, only, seed)"),
    ],
)  # fmt: skip
def test_bad_parameters_are_refused_at_their_line(
    tmp_path: Path, params: dict[str, Any], message: str
) -> None:
    document = default_document()
    document["conditions"]["copy"]["params"] = params
    error = refusal(tmp_path, document)
    assert error.problems == [message]
    path = tmp_path / "study.yaml"
    key = next(iter(params))
    line = line_of(path, f"{key}:", after="  copy:")
    assert error.located == [f"{path}:{line}: {message}"]


def test_an_unknown_behaviour_and_a_bad_choice_are_refused(tmp_path: Path) -> None:
    document = default_document()
    document["conditions"]["copy"]["behaviour"] = "mimic"
    document["conditions"]["natural"]["params"] = {"source": "recorded", "loop": "yes"}
    problems = refusal(tmp_path, document).problems
    assert problems == [
        "conditions.natural.params.source: must be one of clip, yoked, synthetic, got 'recorded'",
        "conditions.natural.params.loop: must be true or false, got 'yes'",
        "conditions.copy.behaviour: unknown behaviour 'mimic' (available: copy, natural, "
        "still, yoked_copy)",
    ]


def test_a_plug_in_behaviour_declares_its_parameters(tmp_path: Path) -> None:
    """The loader asks the behaviour registry; a lab's behaviour brings its declaration."""
    behaviours = {
        "still": {},
        "smile": {"intensity": Param("number", 0.5, minimum=0.0, maximum=1.0)},
    }
    document = default_document()
    document["conditions"] = {
        "still": {"label": "Still", "behaviour": "still"},
        "smile": {"label": "Smile", "behaviour": "smile", "params": {"intensity": 0.8}},
        "smile_big": {"label": "Big smile", "behaviour": "smile", "params": {"intensity": 2}},
    }
    error = refusal(tmp_path, document, behaviours=behaviours)
    assert error.problems == ["conditions.smile_big.params.intensity: must be a number in 0..1, "
                              "got 2"]  # fmt: skip
    document["conditions"]["smile_big"]["params"]["intensity"] = 1
    study = load_study(write_study(tmp_path, document), behaviours=behaviours)
    assert study.condition("smile_big").params == {"intensity": 1.0}


def test_a_snapshot_keeps_a_behaviour_this_machine_does_not_have() -> None:
    config = json.loads(json.dumps(load_study_default_config()))
    config["conditions"][0] = {"id": "smile", "label": "Smile", "description": "",
                               "behaviour": "smile", "params": {"intensity": 0.8}}  # fmt: skip
    study = study_from_config(config)
    assert (study.conditions[0].behaviour, study.conditions[0].params) == (
        "smile", {"intensity": 0.8},
    )  # fmt: skip


def load_study_default_config() -> dict[str, Any]:
    from chameleons.experiment.study import load_default_study

    return load_default_study().config


@pytest.mark.parametrize("count", [1, 7])
def test_two_to_six_conditions(tmp_path: Path, count: int) -> None:
    document = default_document()
    document["conditions"] = {
        f"c{n}": {"label": f"C{n}", "behaviour": "copy", "params": {"delay": float(n)}}
        for n in range(count)
    }
    problems = refusal(tmp_path, document).problems
    assert f"conditions: needs 2 to 6 conditions, got {count}" in problems


def test_the_suggestion_rule_is_a_setting(tmp_path: Path) -> None:
    document = default_document()
    assert load_study(write_study(tmp_path, document)).suggestion_rule == "expert_place"
    for rule in ("best_move", "up_only"):
        document["suggestion_rule"] = rule
        assert load_study(write_study(tmp_path, document)).suggestion_rule == rule
    del document["suggestion_rule"]  # a new study file without the key gets the default
    assert load_study(write_study(tmp_path, document)).suggestion_rule == "expert_place"
    document["suggestion_rule"] = "greedy"
    assert refusal(tmp_path, document).problems == [
        "suggestion_rule: must be one of ['expert_place', 'best_move', 'up_only'], got 'greedy'"
    ]


def test_a_snapshot_keeps_the_rule_it_ran_under() -> None:
    """A study stored under best_move (the default before expert_place) keeps it."""
    config = json.loads(json.dumps(load_study_default_config()))
    config["suggestion_rule"] = "best_move"
    assert study_from_config(config).suggestion_rule == "best_move"


def test_a_snapshot_stored_before_the_settings_existed_gets_what_ran_then() -> None:
    """Old snapshots: conditions named their behaviour, the rule was up-only, names were
    drawn per session and faces/voices were not matched."""
    config = json.loads(json.dumps(load_study_default_config()))
    del config["suggestion_rule"], config["personas"]
    for condition in config["conditions"]:
        del condition["behaviour"], condition["params"]
    study = study_from_config(config)
    assert study.suggestion_rule == "up_only"
    assert (study.personas.names, study.personas.faces, study.personas.match_gender) == (
        "per_interaction", "independent", False,
    )  # fmt: skip
    assert [c.behaviour for c in study.conditions] == ["still", "natural", "copy"]


def test_personas_and_face_and_name_genders_load(tmp_path: Path) -> None:
    study = load_study(write_study(tmp_path, default_document()))
    assert (study.personas.names, study.personas.faces, study.personas.match_gender) == (
        "per_actor", "independent", True,
    )  # fmt: skip
    assert [(f.gender, f.age) for f in study.faces] == [
        ("female", "young adult"), ("male", "adult"), ("female", "young adult"),
        ("male", "older adult"),
    ]  # fmt: skip
    assert study.name_genders["Iris"] == "female"
    assert study.name_genders["Theo"] == "male"


def test_bad_persona_settings_are_refused(tmp_path: Path) -> None:
    document = default_document()
    document["personas"] = {"names": "per_voice", "faces": "fixed", "colour": 1}
    document["faces"]["face-1"]["gender"] = "woman"
    problems = refusal(tmp_path, document).problems
    assert problems == [
        "faces.face-1.gender: must be one of ['female', 'male', 'other'], got 'woman'",
        "personas.colour: unknown key (expected one of ['faces', 'match_gender', 'names'])",
        "personas.names: must be one of ['per_actor', 'per_interaction'], got 'per_voice'",
        "personas.faces: must be one of ['independent', 'per_actor'], got 'fixed'",
    ]


def test_gender_matching_needs_enough_faces_and_names_of_each_gender(tmp_path: Path) -> None:
    document = default_document()
    document["faces"]["face-2"]["gender"] = "female"  # three female faces, one male
    document["robot_names"] = [n for n in document["robot_names"] if n["gender"] == "female"]
    problems = refusal(tmp_path, document).problems
    assert problems == [
        "faces: has 1 fitting male voices, but 2 are needed (distinct ones in a session; "
        "personas.match_gender keeps genders apart)",
        "robot_names: has 0 fitting male voices, but 2 are needed (one per actor; "
        "personas.match_gender keeps genders apart)",
    ]
    # Without the match the same faces and names do.
    document["personas"]["match_gender"] = False
    assert load_study(write_study(tmp_path, document)).personas.match_gender is False


def test_faces_tied_to_actors_need_a_face_per_actor(tmp_path: Path) -> None:
    document = default_document()
    document["personas"]["faces"] = "per_actor"
    del document["faces"]["face-4"]
    problems = refusal(tmp_path, document).problems
    assert problems[0].startswith("faces: has 1 fitting male voices, but 2 are needed (one per "
                                  "actor")  # fmt: skip


def test_an_actor_may_name_its_furhat_voice_per_language_without_changing_older_hashes(
    tmp_path: Path,
) -> None:
    plain = load_study(write_study(tmp_path, default_document(), "plain.yaml"))
    assert all(a.voice.furhat_voice("en") is None for a in plain.actors)
    document = default_document()
    document["actors"]["m1"]["voice"]["furhat"] = "Matthew-Neural"
    document["actors"]["f1"]["voice"]["furhat"] = {"en": "Joanna-Neural", "sv": "Astrid"}
    study = load_study(write_study(tmp_path, document))
    assert study.actor("m1").voice.furhat_voice("sv") == "Matthew-Neural"  # every language
    assert study.actor("f1").voice.furhat_voice("en") == "Joanna-Neural"
    assert study.actor("f1").voice.furhat_voice("sv") == "Astrid"
    assert study.actor("f2").voice.furhat_voice("en") is None  # the robot's own voice
    assert study.content_hash != plain.content_hash
    again = study_from_config(json.loads(json.dumps(study.config)))
    assert again.content_hash == study.content_hash
    assert again.actor("f1").voice.furhat == study.actor("f1").voice.furhat
    assert "furhat" not in plain.config["actors"][0]["voice"]  # a study without keeps its hash


def test_a_bad_furhat_voice_is_refused(tmp_path: Path) -> None:
    document = default_document()
    document["actors"]["m1"]["voice"]["furhat"] = " "
    document["actors"]["m2"]["voice"]["furhat"] = {"english": "Matthew", "sv": ""}
    assert refusal(tmp_path, document).problems == [
        "actors.m1.voice.furhat: must name a Furhat voice, or one per language ({en: ...})",
        "actors.m2.voice.furhat.english: must be a language code with a voice name",
        "actors.m2.voice.furhat.sv: must be a language code with a voice name",
    ]


def test_a_condition_may_choose_the_robot_displays_face(tmp_path: Path) -> None:
    """Embodiment as a factor: conditions that differ only in the display's renderer."""
    document = default_document()
    document["conditions"] = {
        "copy_2d": {"label": "Copy, flat face", "behaviour": "copy", "renderer": "2d"},
        "copy_3d": {"label": "Copy, 3D head", "behaviour": "copy", "renderer": "3d"},
        "still": {"label": "Still", "behaviour": "still"},
    }
    study = load_study(write_study(tmp_path, document))
    assert [(c.id, c.renderer) for c in study.conditions] == [
        ("copy_2d", "2d"), ("copy_3d", "3d"), ("still", None),
    ]  # fmt: skip
    stored = json.loads(json.dumps(study.config))
    assert stored["conditions"][1]["renderer"] == "3d"
    assert "renderer" not in stored["conditions"][2]
    assert study_from_config(stored) == study
    assert study_from_config(stored).condition("copy_3d").renderer == "3d"
    # A study that names no renderer stores (and hashes) its conditions as before.
    assert all("renderer" not in c for c in load_study(default_study_path()).config["conditions"])


def test_a_bad_renderer_is_refused_at_its_line(tmp_path: Path) -> None:
    document = default_document()
    document["conditions"]["copy"]["renderer"] = "4d"
    with pytest.raises(StudyError) as error:
        load_study(write_study(tmp_path, document))
    assert "conditions.copy.renderer: must be 2d or 3d" in str(error.value)
