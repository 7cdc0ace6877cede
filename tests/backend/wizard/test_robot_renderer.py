"""Embodiment as a study factor: conditions that name the virtual robot display's face
(2D or 3D) or the booth's Furhat send it with the face to the worker, record it on the
interaction, and export it; a booth without a Furhat says why a Furhat condition was not
set."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI

from chameleons.backend.db import session_scope
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.backend.wizard.conftest import api
from tests.backend.wizard.test_worker_path import BOOTH, bridge, until, worker
from tests.experiment.study_files import default_document, study_yaml
from tests.support.bots import WizardBot, study_with_plan
from tests.worker.furhat_peer import FurhatPeer

__all__ = ["bridge", "worker"]


def embodiment_study() -> str:
    document = default_document()
    document["conditions"] = {
        "copy_2d": {"label": "Copy, flat face", "behaviour": "copy", "renderer": "2d"},
        "copy_3d": {"label": "Copy, 3D head", "behaviour": "copy", "renderer": "3d"},
        "still": {"label": "Still", "behaviour": "still"},
    }
    return study_yaml(document)


@pytest.mark.usefixtures("worker")
def test_the_condition_s_renderer_goes_with_the_face_and_is_recorded(
    app: FastAPI, wizard: WizardBot, bridge: Any, tmp_path: Path
) -> None:
    study = study_with_plan(wizard.staff, 6, yaml=embodiment_study())
    wizard = WizardBot.create(wizard.staff, study)
    applied = {}
    for condition in ("copy_3d", "still", "copy_2d"):
        wizard.switch_condition(condition, 1)
        result = wizard.staff.post(f"{api(wizard)}/robot/apply")
        assert result["kind"] == "robot.applied", result
        applied[condition] = (result["renderer"], bridge.state(BOOTH).face)
    face = wizard.interaction(1)["face"]
    assert applied == {
        "copy_3d": ("3d", {"face_id": face, "renderer": "3d"}),
        "still": (None, {"face_id": face}),
        "copy_2d": ("2d", {"face_id": face, "renderer": "2d"}),
    }
    with session_scope(app.state.sessionmaker) as db:
        export_to_directory(db, ExportRequest(study_id=study), tmp_path)
    with (tmp_path / "interactions.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert rows  # the interaction whose robot was set up
    first = next(r for r in rows if r["position"] == "1" and r["session"] == str(wizard.session_id))
    assert (first["condition"], first["renderer"]) == ("copy_2d", "2d")


def furhat_study() -> str:
    document = default_document()
    document["conditions"] = {
        "copy_2d": {"label": "Copy, flat face", "behaviour": "copy", "renderer": "2d"},
        "copy_furhat": {"label": "Copy, Furhat", "behaviour": "copy", "renderer": "furhat"},
        "still": {"label": "Still", "behaviour": "still"},
    }
    return study_yaml(document)


@pytest.mark.usefixtures("worker")
def test_a_booth_without_a_furhat_says_why_a_furhat_condition_was_not_set(
    wizard: WizardBot,
) -> None:
    study = study_with_plan(wizard.staff, 6, yaml=furhat_study())
    wizard = WizardBot.create(wizard.staff, study)
    wizard.switch_condition("copy_furhat", 1)
    result = wizard.staff.post(f"{api(wizard)}/robot/apply")
    assert result["kind"] == "robot.not_applied", result
    assert ("this booth drives no Furhat (its worker's driver is null): a furhat condition "
            "needs a worker started with --driver furhat or --driver virtual+furhat"
            ) in result["face_result"]["detail"]  # fmt: skip


def test_a_booth_with_both_robots_runs_the_furhat_condition_on_the_furhat(
    app: FastAPI, wizard: WizardBot, bridge: Any, tmp_path: Path
) -> None:
    study = study_with_plan(wizard.staff, 6, yaml=furhat_study())
    wizard = WizardBot.create(wizard.staff, study)
    with FurhatPeer() as robot:
        config = WorkerConfig(booth=BOOTH, driver="virtual+furhat", robot_url=robot.url,
                              livelink_port=None, facecapturex_port=None, data_dir=tmp_path,
                              command_endpoint=bridge.command_endpoint,
                              telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
        with Worker(config):
            until(lambda: BOOTH in bridge.workers())
            robot.wait_for(lambda p: bool(p.of_type("request.face.config")), timeout=10)
            configs = len(robot.of_type("request.face.config"))
            wizard.switch_condition("copy_furhat", 1)
            result = wizard.staff.post(f"{api(wizard)}/robot/apply")
            assert result["kind"] == "robot.applied", result
            # The Furhat was given the face (the display is not driven meanwhile).
            robot.wait_for(lambda p: len(p.of_type("request.face.config")) > configs,
                           timeout=10)  # fmt: skip
    assert result["renderer"] == "furhat"
    assert bridge.state(BOOTH).face["renderer"] == "furhat"
    with session_scope(app.state.sessionmaker) as db:
        export_to_directory(db, ExportRequest(study_id=study), tmp_path)
    with (tmp_path / "interactions.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    first = next(r for r in rows if r["position"] == "1" and r["session"] == str(wizard.session_id))
    assert (first["condition"], first["renderer"]) == ("copy_furhat", "furhat")
