"""Questionnaire items: ``required`` (open questions optional by default), the loader's
warning about wording shared between questionnaires, and Cronbach's alpha per scale from
the export's long answers table."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from chameleons.experiment.stats.reliability import cronbach_alpha
from chameleons.experiment.stats.scale_reliability import scale_reliability
from chameleons.experiment.study import (
    StudyError,
    load_default_study,
    load_study,
    study_from_config,
)
from tests.experiment.study_files import default_document, write_study


def test_open_questions_are_optional_and_rated_items_required_by_default() -> None:
    study = load_default_study()
    final = study.questionnaire("final")
    assert [(i.id, i.required) for i in final.items][:2] == [
        ("differences", False),
        ("comments", False),
    ]
    assert all(i.required for i in study.questionnaire("credibility").items)


def test_required_can_be_set_either_way_and_survives_the_snapshot(tmp_path: Path) -> None:
    document = default_document()
    document["questionnaires"]["final"]["items"][0]["required"] = True
    document["questionnaires"]["trust"]["items"][2]["required"] = False
    study = load_study(write_study(tmp_path, document))
    assert study.questionnaire("final").items[0].required is True
    assert study.questionnaire("trust").items[2].required is False
    rebuilt = study_from_config(json.loads(json.dumps(study.config)))
    assert rebuilt == study
    assert rebuilt.questionnaire("final").items[0].required is True


def test_a_default_required_is_not_stored_so_old_snapshots_keep_their_hash() -> None:
    study = load_default_study()
    items = [i for q in study.config["questionnaires"] for i in q["items"]]
    assert not any("required" in item for item in items if item["type"] in ("differential", "text"))
    assert all("options" not in item for item in items if item["type"] != "choice")


def test_required_must_be_a_boolean_with_its_line(tmp_path: Path) -> None:
    document = default_document()
    document["questionnaires"]["final"]["items"][1]["required"] = "no"
    path = write_study(tmp_path, document)
    with pytest.raises(StudyError) as caught:
        load_study(path)
    line = next(
        n for n, text in enumerate(path.read_text().splitlines(), 1) if "required: 'no'" in text
    )
    place = "questionnaires.final.items[1].required"
    assert caught.value.located == [f"{path}:{line}: {place}: must be true or false, got text 'no'"]


def test_the_loader_warns_about_wording_shared_between_questionnaires() -> None:
    """The default scales share two items with their sources (docs/science.md)."""
    warnings = load_default_study().warnings
    assert len(warnings) == 2
    assert "questionnaires.likeability.items[0]: 'The robot is friendly.'" in warnings[0]
    assert "questionnaires.credibility.items[7] (Friendly/Unfriendly)" in warnings[0]
    assert "questionnaires.trust.items[0]: Honest/Dishonest repeats" in warnings[1]
    assert "questionnaires.credibility.items[6] (Dishonest/Honest)" in warnings[1]
    assert all(w.startswith("/") and "study.yaml:" in w for w in warnings)  # file:line


def test_a_copied_item_is_named_with_its_line_and_a_unique_one_is_not(tmp_path: Path) -> None:
    document = default_document()
    document["questionnaires"]["trust"]["items"].append(
        {"id": "pleasant_again", "type": "differential", "left": "Pleasant", "right": "Unpleasant"}
    )
    path = write_study(tmp_path, document)
    warnings = load_study(path).warnings
    extra = [w for w in warnings if "trust.items[6]" in w]
    assert len(extra) == 1
    assert "repeats questionnaires.credibility.items[8]" in extra[0]
    line = next(n for n, t in enumerate(path.read_text().splitlines(), 1) if "pleasant_again" in t)
    assert extra[0].startswith(f"{path}:{line}: ")
    document["questionnaires"]["trust"]["items"][-1] = {
        "id": "calm", "type": "differential", "left": "Calm", "right": "Nervous"
    }  # fmt: skip
    assert len(load_study(write_study(tmp_path, document)).warnings) == 2


def _rows(scale: str, cases: list[list[int]], participant: str = "P") -> list[dict[str, object]]:
    study = load_default_study()
    items = study.questionnaire(scale).numeric_items
    return [
        {
            "participant": f"{participant}{n // 3}",
            "session": n // 3,
            "position": n % 3 + 1,
            "questionnaire": scale,
            "item": item.id,
            "value": value,
            "scored_value": (8 - value) if item.reverse else value,
            "skipped": False,
        }
        for n, case in enumerate(cases)
        for item, value in zip(items, case, strict=True)
    ]


def test_alpha_per_scale_uses_complete_scored_cases_of_the_chosen_participants() -> None:
    rng = np.random.default_rng(4)
    study = load_default_study()
    trust = [list(map(int, rng.integers(1, 8, 6))) for _ in range(12)]
    rows = _rows("trust", trust)
    # An incomplete case (one item skipped) is left out, and so is a participant not chosen.
    rows[0] = {**rows[0], "value": None, "scored_value": None, "skipped": True}
    results = {r.scale: r for r in scale_reliability(study.questionnaires, rows)}
    assert set(results) == {"credibility", "likeability", "trust"}
    assert results["credibility"].n == 0
    assert results["credibility"].alpha is None
    items = list(study.questionnaire("trust").numeric_items)
    scored = [[(8 - v) if i.reverse else v for i, v in zip(items, c, strict=True)] for c in trust]
    expected = cronbach_alpha("trust", [i.id for i in items], scored[1:])
    # The same alpha; its interval resamples participants (three ratings each here).
    assert (results["trust"].alpha, results["trust"].n) == (expected.alpha, expected.n)
    assert results["trust"].if_deleted == expected.if_deleted
    assert results["trust"].method == "percentile bootstrap over participants"
    chosen = {"P1", "P2", "P3"}
    only = {r.scale: r for r in scale_reliability(study.questionnaires, rows, chosen)}
    assert only["trust"].alpha == cronbach_alpha("trust", [i.id for i in items], scored[3:12]).alpha


def test_alpha_from_a_csv_without_scored_values_reverses_the_raw_ones() -> None:
    rng = np.random.default_rng(5)
    study = load_default_study()
    trust = [list(map(int, rng.integers(1, 8, 6))) for _ in range(9)]
    rows = _rows("trust", trust)
    raw = [
        {k: str(v) for k, v in row.items() if k not in ("scored_value", "skipped")} for row in rows
    ]
    from_raw = scale_reliability(study.questionnaires, raw)[2]
    assert from_raw == scale_reliability(study.questionnaires, rows)[2]
    assert from_raw.alpha is not None
