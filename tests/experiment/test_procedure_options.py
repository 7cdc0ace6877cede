"""The procedure in the study file: consent and debriefing pages, choice and robot items,
questionnaires before the interactions; each option loads and survives the snapshot, each
refusal names its place and line."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from chameleons.experiment.model import Choice
from chameleons.experiment.study import (
    StudyError,
    load_default_study,
    load_study,
    study_from_config,
)
from tests.experiment.study_files import default_document, write_study


def located(tmp_path: Path, document: dict[str, Any]) -> list[str]:
    with pytest.raises(StudyError) as caught:
        load_study(write_study(tmp_path, document))
    return caught.value.located


def line(path: Path, text: str) -> int:
    return next(n for n, t in enumerate(path.read_text().splitlines(), 1) if text in t)


def test_the_default_study_has_the_whole_procedure() -> None:
    study = load_default_study()
    consent = study.procedure.consent
    assert consent is not None
    assert (consent.version, consent.agree) == ("consent-v1", "I agree to take part")
    assert "\n\n" in consent.text  # paragraphs kept
    assert study.procedure.debriefing is not None
    before = study.questionnaires_for("before")
    assert [q.id for q in before] == ["demographics"]
    assert all(not item.required and item.type == "choice" for item in before[0].items)
    final = {item.id: item for item in study.questionnaire("final").items}
    assert final["imitating_robot"].type == "robot"
    assert final["noticed_imitation"].options[0] == Choice("yes", "Yes")
    assert not before[0].scored  # choices are not rated, so no score and no measure


def test_a_study_without_a_procedure_has_no_consent_and_keeps_its_hash(tmp_path: Path) -> None:
    document = default_document()
    document.pop("procedure")
    study = load_study(write_study(tmp_path, document))
    assert study.procedure.consent is None
    assert "procedure" not in study.config
    rebuilt = study_from_config(json.loads(json.dumps(study.config)))
    assert (rebuilt, rebuilt.content_hash) == (study, study.content_hash)


def test_the_procedure_and_choices_survive_the_snapshot() -> None:
    study = load_default_study()
    rebuilt = study_from_config(json.loads(json.dumps(study.config)))
    assert rebuilt == study
    assert rebuilt.procedure == study.procedure
    assert rebuilt.content_hash == study.content_hash
    assert rebuilt.questionnaire("demographics") == study.questionnaire("demographics")


def test_plain_text_options_get_snake_case_ids(tmp_path: Path) -> None:
    document = default_document()
    document["questionnaires"]["demographics"]["items"][2]["options"] = ["Never", "Quite often"]
    study = load_study(write_study(tmp_path, document))
    options = study.questionnaire("demographics").items[2].options
    assert options == (Choice("never", "Never"), Choice("quite_often", "Quite often"))


def test_refusals_name_their_place_and_line(tmp_path: Path) -> None:
    document = default_document()
    document["procedure"]["consent"].pop("text")
    document["procedure"]["debriefing"]["colour"] = "blue"
    items = document["questionnaires"]["demographics"]["items"]
    items[0]["options"] = [{"id": "one", "label": "One"}]
    items[1]["options"][1]["id"] = "woman"
    document["questionnaires"]["experience"]["items"].append(
        {"id": "which", "type": "robot", "text": "Which robot?"}
    )
    problems = located(tmp_path, document)
    path = tmp_path / "study.yaml"
    assert f"{path}:{line(path, '  consent:')}: procedure.consent.text: is missing" in problems
    assert any(
        p.startswith(f"{path}:{line(path, 'colour: blue')}: procedure.debriefing.colour: unknown")
        for p in problems
    )
    options = "questionnaires.demographics.items[0].options"
    assert any(p.endswith(f"{options}: needs at least 2 options, got 1") for p in problems)
    twice = "questionnaires.demographics.items[1].options[1].id: option id 'woman' used twice"
    assert any(p.endswith(twice) for p in problems)
    robot = "questionnaires.experience.items[1].type: a robot item belongs in a final questionnaire"
    assert any(p.endswith(robot) for p in problems)
    assert len(problems) == 5


def test_a_choice_needs_options_and_a_phase_must_be_known(tmp_path: Path) -> None:
    document = default_document()
    document["questionnaires"]["demographics"]["items"][0].pop("options")
    document["questionnaires"]["demographics"]["phase"] = "after"
    problems = located(tmp_path, document)
    assert any(
        p.endswith("questionnaires.demographics.items[0].options: is missing") for p in problems
    )
    assert any(
        p.endswith("questionnaires.demographics.phase: must be one of "
                   "['before', 'interaction', 'final'], got 'after'")
        for p in problems
    )  # fmt: skip
