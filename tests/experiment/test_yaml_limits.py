"""A study file's anchors and aliases are counted out before anything is built from them:
a "billion laughs" file is refused at once with a sentence, as is one that contains
itself or nests hundreds of levels deep; the few aliases a lab writes still load."""

from __future__ import annotations

from pathlib import Path

import pytest

from chameleons.experiment.study import StudyError, default_study_path, load_study
from chameleons.experiment.yaml_limits import MAX_VALUES
from tests.experiment.study_files import default_document, laughs, study_yaml

TOO_LARGE = (
    f"too large: the document stands for more than {MAX_VALUES} values once its aliases "
    "(*name) are expanded: write the repeated parts out, or repeat them less"
)


def _problems(tmp_path: Path, text: str) -> list[str]:
    path = tmp_path / "study.yaml"
    path.write_text(text, "utf-8")
    with pytest.raises(StudyError) as refused:
        load_study(path)
    return refused.value.problems


@pytest.mark.parametrize("levels", [6, 9])  # 531,441 and 387,420,489 values
def test_a_billion_laughs_is_refused_by_its_count_before_anything_is_built(
    tmp_path: Path, levels: int
) -> None:
    """Before, every walk went through each repetition (62 s and 490 MB for one such file
    on the studies API) and the file was refused only for its unknown keys."""
    text = default_study_path().read_text("utf-8") + laughs(levels)
    assert len(text.encode()) < 40_000
    assert _problems(tmp_path, text) == [TOO_LARGE]


def test_a_node_that_contains_itself_is_refused(tmp_path: Path) -> None:
    text = default_study_path().read_text("utf-8") + "loop: &loop [1, *loop]\n"
    line = text.count("\n")
    assert _problems(tmp_path, text) == [
        f"too large: an alias refers to a node that contains it (line {line})"
    ]


def test_hundreds_of_nested_levels_are_refused_with_a_sentence(tmp_path: Path) -> None:
    text = "deep: " + "[" * 5000 + "]" * 5000 + "\n"
    assert _problems(tmp_path, text) == [
        "nested too deeply: a study needs a few levels, not hundreds"
    ]


def test_the_aliases_a_lab_writes_still_load(tmp_path: Path) -> None:
    document = default_document()
    document.update(name="Pilot", description="SAME AS THE NAME")
    text = study_yaml(document).replace("name: Pilot\n", "name: &title Pilot\n", 1)
    path = tmp_path / "study.yaml"
    path.write_text(text.replace("description: SAME AS THE NAME\n", "description: *title\n"))
    study = load_study(path)
    assert study.name == "Pilot"
    assert study.config["description"] == "Pilot"
