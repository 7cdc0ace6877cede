"""``copy``'s design-space parameters in the study file: loaded as given, refused with the
file, the line, the condition and the field, and described in words."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from chameleons.experiment.study import StudyError, load_study, study_from_config
from chameleons.worker.behaviours.copy_params import in_words, settings_of
from tests.experiment.study_files import default_document, write_study


def load_copy(tmp_path: Path, params: dict[str, Any]) -> dict[str, Any]:
    document = default_document()
    document["conditions"]["copy"]["params"] = params
    study = load_study(write_study(tmp_path, document))
    assert study_from_config(json.loads(json.dumps(study.config))) == study
    return dict(study.condition("copy").params)


def test_the_design_space_loads_as_given(tmp_path: Path) -> None:
    params = {
        "channels": ["head", "mouthSmileLeft", "HeadYaw"], "gain": {"head": 0.5},
        "mirror": False, "delay": {"uniform": [0.5, 1.0]}, "delay_resample_s": 5,
        "intermittent": {"rate_per_s": 0.2, "bout_s": 3}, "seed": 9,
    }  # fmt: skip
    assert load_copy(tmp_path, params) == {
        "channels": ["head", "mouthSmileLeft", "HeadYaw"], "gain": {"head": 0.5},
        "mirror": False, "delay": {"uniform": [0.5, 1.0]}, "delay_resample_s": 5.0,
        "intermittent": {"rate_per_s": 0.2, "bout_s": 3.0, "rest": "neutral"}, "seed": 9,
    }  # fmt: skip


def test_a_study_without_the_new_parameters_stores_what_it_did_before(tmp_path: Path) -> None:
    assert load_copy(tmp_path, {"delay": 0.7}) == {"delay": 0.7}
    assert load_copy(tmp_path, {"coexpress": True}) == {"delay": 0.0, "coexpress": True}


@pytest.mark.parametrize(
    ("params", "field", "message"),
    [
        ({"channels": "nose"}, "channels", "'nose' is not a channel: use one of all, head,"),
        ({"channels": ["head", "mouthSmile"]}, "channels", "'mouthSmile' is not a channel"),
        ({"gain": {"ears": 2}}, "gain", "'ears' is not a channel"),
        ({"gain": 5}, "gain", "must be a number in 0..3 or a mapping"),
        ({"mirror": "yes"}, "mirror", "must be true (mirror image), false (same side)"),
        ({"delay": {"uniform": [2, 1]}}, "delay", "uniform must be [low, high] seconds"),
        ({"delay": {"gamma": 1}}, "delay", "'gamma' is not a distribution"),
        ({"delay": {"normal": {"mean": 1}}}, "delay", "normal must be {mean:"),
        ({"coexpress": True, "delay": 1.0}, "coexpress", "means zero lag"),
        ({"intermittent": {"rate_per_s": 0.5}}, "intermittent", "must be {rate_per_s"),
        ({"intermittent": {"rate_per_s": 0.5, "bout_s": 0.1}}, "intermittent", "bout_s must"),
        ({"intermittent": {"rate_per_s": 0.5, "bout_s": 1, "rest": "idle"}}, "intermittent",
         "rest must be neutral or natural"),
        ({"only": ["winks"]}, "only", "'winks' is not a named expression (smiles, nods,"),
        ({"only": ["smiles"], "channels": "head"}, "only", "leave channels out"),
        ({"delay_resample_s": 5}, "delay_resample_s", "only applies to a delay distribution"),
    ],
)  # fmt: skip
def test_bad_values_are_located_errors(
    tmp_path: Path, params: dict[str, Any], field: str, message: str
) -> None:
    document = default_document()
    document["conditions"]["copy"]["params"] = params
    path = write_study(tmp_path, document)
    with pytest.raises(StudyError) as caught:
        load_study(path)
    (problem,) = caught.value.problems
    assert problem.startswith(f"conditions.copy.params.{field}: ")
    assert message in problem
    (located,) = caught.value.located
    assert located.startswith(f"{path}:")
    assert message in located


def test_the_settings_are_said_in_words() -> None:
    assert in_words({"delay": 4.0}, booth_mirror=True) == (
        "copies everything, 4 s late, mirror image"
    )
    assert in_words({"channels": "head", "delay": 4.0, "gain": 0.5}) == (
        "copies head, 4 s late, gain x0.5"
    )
    assert in_words({"only": ["nods"], "coexpress": True, "delay": 0.0, "mirror": False}) == (
        "copies only nods (head pitch >= 5 deg), at zero lag (co-expression), same side"
    )
    jittered = {
        "delay": {"uniform": [0.5, 1.0]},
        "seed": 3,
        "intermittent": {"rate_per_s": 0.2, "bout_s": 3.0, "rest": "natural"},
    }
    assert in_words(jittered) == (
        "copies everything, 0.5-1 s late (uniform, redrawn per bout), "
        "in 3 s bouts at 0.2/s, rest natural, seed 3"
    )
    assert settings_of({})["delay"] == 4.0
    assert settings_of({"coexpress": True})["delay"] == 0.0
