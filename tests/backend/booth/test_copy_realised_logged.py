"""What a jittered copy drew reaches the study's records (issue 31): a real worker runs the
interaction's ``copy`` with a delay distribution, reports each delay it draws and shows, the
booth flow logs each as ``robot.copy_draw`` of the running interaction, and the export's
``interactions.csv`` summarises them (realised mean, SD, number of draws) beside the
parameters."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from fastapi import FastAPI

from chameleons.backend.bridge import Bridge
from chameleons.backend.db import session_scope
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.worker.behaviours.copy_timing import DelaySchedule
from tests.backend.booth.conftest import (
    new_session,
    running_worker,
    timeline,
    until,
    wait_for_event,
    worker_config,
)
from tests.experiment.study_files import default_document, study_yaml
from tests.support.bots import StaffApi, study_with_plan
from tests.worker.head_stream import Pose, stream

pytestmark = pytest.mark.usefixtures("flow")
JITTER = {"uniform": [0.5, 1.5]}


def jitter_study(pi: StaffApi) -> int:
    document = default_document()
    document["conditions"] = {
        "jitter": {"label": "Copy, jittered", "behaviour": "copy",
                   "params": {"delay": JITTER, "delay_resample_s": 0.5}},
        "fixed": {"label": "Copy, 4 s", "behaviour": "copy", "params": {"delay": 4.0}},
        "still": {"label": "Still", "behaviour": "still"},
    }  # fmt: skip
    return study_with_plan(pi, 6, yaml=study_yaml(document))


def test_the_delays_a_jittered_copy_drew_are_logged_and_exported(
    app: FastAPI, pi: StaffApi, bridge: Bridge, tmp_path: Path
) -> None:
    study = jitter_study(pi)
    wizard, _ = new_session(pi, study)
    with running_worker(bridge, worker_config(bridge, tmp_path)) as worker:
        wizard.start()
        wizard.switch_condition("jitter", 1)
        wizard.advance(1, "discussion")  # the flow sets the robot up with the interaction's seed
        applied = wait_for_event(wizard, "robot.applied")
        stream(worker.receivers["livelink"].port, Pose(turn_at=0.5), 4.0)

        def draws() -> list[dict[str, object]]:
            found = [e for e in timeline(wizard) if e["kind"] == "robot.copy_draw"]
            return found if len(found) >= 6 else []

        logged = until(draws, what="six robot.copy_draw events")
    seed = applied["payload"]["params"]["seed"]
    interaction_id = applied["interaction_id"]
    assert seed == interaction_id  # the server's seed: the interaction's id
    assert {e["interaction_id"] for e in logged} == {interaction_id}
    assert all(e["worker_time"] is not None for e in logged)
    payloads = sorted((e["payload"] for e in logged), key=lambda p: p["block"])
    schedule = DelaySchedule(JITTER, seed, 0.5, maximum=11.5)
    assert [p["delay_s"] for p in payloads] == [schedule.draw(p["block"]) for p in payloads]
    with session_scope(app.state.sessionmaker) as db:
        export_to_directory(db, ExportRequest(study_id=study, include_rehearsal=True), tmp_path)
    with (tmp_path / "interactions.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    row = next(r for r in rows if r["session"] == str(wizard.session_id) and r["position"] == "1")
    delays = [p["delay_s"] for p in payloads]
    assert int(row["delay_draws"]) >= len(delays)  # more may have come since
    everything = [e["payload"]["delay_s"] for e in timeline(wizard)
                  if e["kind"] == "robot.copy_draw"]  # fmt: skip
    assert int(row["delay_draws"]) == len(everything)
    assert float(row["realised_delay_mean_s"]) == pytest.approx(np.mean(everything), abs=1e-4)
    assert float(row["realised_delay_sd_s"]) == pytest.approx(np.std(everything, ddof=1), abs=1e-4)
    assert row["copy_bouts"] == ""
    codebook = (tmp_path / "codebook.csv").read_text(encoding="utf-8")
    assert "realised_delay_mean_s" in codebook
