"""Copy's design-space parameters reach the worker with a seed per interaction, are logged
with the robot's set-up, recorded on the interaction and exported, in JSON and in words."""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI

from chameleons.backend.db import session_scope
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.models import Interaction
from tests.backend.wizard.conftest import api
from tests.backend.wizard.test_worker_path import BOOTH, bridge, worker
from tests.experiment.study_files import default_document, study_yaml
from tests.support.bots import WizardBot, study_with_plan

__all__ = ["bridge", "worker"]


def channels_study() -> str:
    document = default_document()
    document["conditions"] = {
        "head": {"label": "Copy head", "behaviour": "copy",
                 "params": {"channels": "head", "delay": 0.7, "mirror": False}},
        "bouts": {"label": "Copy in bouts", "behaviour": "copy",
                  "params": {"intermittent": {"rate_per_s": 0.2, "bout_s": 3}}},
        "still": {"label": "Still", "behaviour": "still"},
    }  # fmt: skip
    return study_yaml(document)


@pytest.mark.usefixtures("worker")
def test_the_parameters_are_sent_logged_recorded_and_exported(
    app: FastAPI, wizard: WizardBot, bridge: Any, tmp_path: Path
) -> None:
    study = study_with_plan(wizard.staff, 6, yaml=channels_study())
    wizard = WizardBot.create(wizard.staff, study)
    wizard.switch_condition("bouts", 1)
    result = wizard.staff.post(f"{api(wizard)}/robot/apply")
    assert result["kind"] == "robot.applied", result
    sent = bridge.state(BOOTH).behaviour
    interaction_id = sent["params"]["seed"]
    with session_scope(app.state.sessionmaker) as db:
        recorded = db.get(Interaction, interaction_id)
        assert recorded is not None
        assert (recorded.session_id, recorded.position) == (wizard.session_id, 1)
        assert recorded.behaviour_params == sent["params"]
        assert recorded.behaviour_words == (
            "copies everything, 4 s late, mirror image, in 3 s bouts at 0.2/s, rest neutral, "
            f"seed {interaction_id}"
        )
    assert sent == {
        "name": "copy",
        "params": {
            "delay": 4.0,
            "intermittent": {"rate_per_s": 0.2, "bout_s": 3.0, "rest": "neutral"},
            "seed": interaction_id,
        },
    }  # fmt: skip  (the server chose the seed: this interaction's)
    assert result["behaviour_words"] == recorded.behaviour_words  # logged with the set-up
    wizard.switch_condition("head", 1)
    assert wizard.staff.post(f"{api(wizard)}/robot/apply")["kind"] == "robot.applied"
    with session_scope(app.state.sessionmaker) as db:
        export_to_directory(db, ExportRequest(study_id=study), tmp_path)
    with (tmp_path / "interactions.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    first = next(r for r in rows if r["position"] == "1" and r["session"] == str(wizard.session_id))
    assert first["condition"] == "head"
    assert json.loads(first["behaviour_params"]) == {
        "channels": "head", "delay": 0.7, "mirror": False}  # fmt: skip
    assert first["behaviour_words"] == "copies head, 0.7 s late, same side"
    codebook = (tmp_path / "codebook.csv").read_text(encoding="utf-8")
    assert "behaviour_params" in codebook
    assert "behaviour_words" in codebook


@pytest.mark.usefixtures("worker")
def test_yoked_copy_replays_the_study_clip_until_another_participant_was_recorded(
    app: FastAPI, wizard: WizardBot, bridge: Any
) -> None:
    document = default_document()
    document["conditions"] = {
        "copy": {"label": "Copy", "behaviour": "copy", "params": {"delay": 0.7}},
        "yoked": {"label": "Yoked", "behaviour": "yoked_copy",
                  "params": {"delay": 0.7, "channels": "head"}},
        "still": {"label": "Still", "behaviour": "still"},
    }  # fmt: skip
    study = study_with_plan(wizard.staff, 6, yaml=study_yaml(document))
    wizard = WizardBot.create(wizard.staff, study)
    wizard.switch_condition("yoked", 1)
    result = wizard.staff.post(f"{api(wizard)}/robot/apply")
    assert result["kind"] == "robot.applied", result
    sent = bridge.state(BOOTH).behaviour
    assert sent == {"name": "yoked_copy", "params": {
        "delay": 0.7, "channels": "head", "path": "prompts:_natural/demo-natural.npz"}}  # fmt: skip
    assert result["behaviour_words"].startswith(
        "replays clip demo-natural (yoked: no recording of another participant yet; "
    )
    assert result["behaviour_words"].endswith(": head, 0.7 s late, mirror image")
