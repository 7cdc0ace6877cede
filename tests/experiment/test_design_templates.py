"""The design-space templates (issue 31): each loads, plans with every condition count exact
at 12 and 24 participants with the real planner, and `chameleons study new` starts a lab's
own study from it."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
from click.testing import CliRunner

from chameleons.cli.main import cli
from chameleons.experiment.design import plan
from chameleons.experiment.prereg import PlanFacts, preregistration
from chameleons.experiment.study import load_study
from chameleons.experiment.templates import study_templates as templates

DESIGN_TEMPLATES = {
    "delay_sweep": ["copy_fast", "copy_slow", "yoked"],
    "channels": ["head", "face", "both"],
    "partial_full": ["full", "nods", "still"],
    "embodiment": ["copy_2d", "copy_3d", "copy_furhat"],
}


@pytest.mark.parametrize("name", list(DESIGN_TEMPLATES))
@pytest.mark.parametrize("participants", [12, 24])
def test_each_template_plans_exactly_balanced(name: str, participants: int) -> None:
    study = load_study(templates()[name])
    assert list(study.condition_ids) == DESIGN_TEMPLATES[name]
    assert study.warnings == ()
    assert "responsiveness" in study.measures  # the responsiveness rating
    assert any(i.id == "noticed_imitation" for i in study.questionnaire("final").items)
    result = plan(study, participants, seed=0)
    assert result.balance.ok
    positions = Counter((i.condition, i.position) for r in result.rows for i in r.interactions)
    assert set(positions.values()) == {participants // 3}  # each condition at each position
    for constraint in result.balance.constraints:
        if not constraint.id.startswith("item_first_last"):  # item order: a fractional ideal
            assert constraint.max_deviation == 0, constraint.id


def test_the_templates_say_what_they_copy() -> None:
    channels = {c.id: c.params for c in load_study(templates()["channels"]).conditions}
    assert channels["head"]["channels"] == "head"
    assert channels["face"]["channels"] == "face"
    partial = {c.id: c.params for c in load_study(templates()["partial_full"]).conditions}
    assert partial["nods"]["only"] == ["nods"]
    embodiment = load_study(templates()["embodiment"]).conditions
    assert [c.renderer for c in embodiment] == ["2d", "3d", "furhat"]


def test_study_new_copies_a_template_and_refuses_what_it_cannot(tmp_path: Path) -> None:
    runner = CliRunner()
    listed = runner.invoke(cli, ["study", "templates"])
    assert listed.exit_code == 0, listed.output
    assert "delay_sweep" in listed.output
    result = runner.invoke(cli, ["study", "new", "--template", "channels", str(tmp_path / "mine")])
    assert result.exit_code == 0, result.output
    written = tmp_path / "mine" / "study.yaml"
    assert load_study(written).condition_ids == load_study(templates()["channels"]).condition_ids
    again = runner.invoke(cli, ["study", "new", "--template", "channels", str(tmp_path / "mine")])
    assert again.exit_code == 1
    assert "exists already" in again.output
    unknown = runner.invoke(cli, ["study", "new", "--template", "nope", str(tmp_path / "x")])
    assert unknown.exit_code == 2
    assert "no template 'nope'" in unknown.output


def test_the_preregistration_states_what_each_copy_condition_copies() -> None:
    study = load_study(templates()["channels"])
    text = preregistration(study, PlanFacts(seed=0, rows=12, config_hash="x", created="2026-12-06"))
    assert "(`head`): The participant's head movements, mirrored 4 s later; the face stays " in text
    assert "The robot copies head, 4 s late, mirrored as the booth's mirror setting says." in text
    partial = load_study(templates()["partial_full"])
    text = preregistration(
        partial, PlanFacts(seed=0, rows=12, config_hash="x", created="2026-12-06")
    )
    assert "The robot copies only nods (head pitch >= 5 deg), 4 s late" in text
