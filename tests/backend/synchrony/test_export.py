"""The synchrony columns in the export: values for every interaction with recordings, a
reason for every other, and the codebook and datapackage schema describing them."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from sqlalchemy import delete, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.models import Interaction, Recording
from chameleons.backend.synchrony import repository, service
from tests.backend.synchrony.recorded import recorded_study
from tests.backend.synchrony.test_service import PARAMS

COLUMNS = ("sync_lag_s", "sync_r", "mimicry_r", "mimicry_lag_s", "sync_check", "sync_missing")


def test_interactions_csv_has_the_four_values_or_a_reason(
    db_session: DbSession, tmp_path: Path
) -> None:
    data = tmp_path / "data"
    study = recorded_study(db_session, data, participants=2)
    ids = repository.interactions_of(db_session, study.study_id)
    no_recording, not_computed = ids[0], ids[1]
    db_session.execute(delete(Recording).where(Recording.interaction_id == no_recording))
    for interaction_id in ids[2:]:
        service.compute(db_session, interaction_id, data, PARAMS)
    out = tmp_path / "export"
    export_to_directory(db_session, ExportRequest(study_id=study.study_id), out)
    with (out / "interactions.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert set(COLUMNS) <= set(rows[0])
    conditions = {i.id: i.condition for i in db_session.scalars(select(Interaction))}
    by_id = dict(zip(ids, rows, strict=True))  # rows in participant/position order = id order
    assert by_id[no_recording]["sync_missing"] == "no_recording"
    assert by_id[no_recording]["sync_r"] == ""
    assert by_id[not_computed]["sync_missing"] == "not_computed"
    assert "chameleons synchrony" in by_id[not_computed]["sync_note"]
    for interaction_id in ids[2:]:
        row = by_id[interaction_id]
        if conditions[interaction_id] == "still":
            assert row["sync_missing"] == "robot_still"
            assert row["sync_r"] == ""
            continue
        assert row["sync_missing"] == ""
        for column in ("sync_lag_s", "sync_r", "mimicry_r", "mimicry_lag_s"):
            assert row[column] != "", column
        if conditions[interaction_id] == "copy":
            assert float(row["sync_lag_s"]) == pytest.approx(4.0, abs=0.05)
            assert row["sync_check"] == "ok"
            assert float(row["sync_r"]) > float(row["sync_surrogate_r"])


def test_codebook_and_datapackage_describe_the_columns(
    db_session: DbSession, tmp_path: Path
) -> None:
    study = recorded_study(db_session, tmp_path / "data", participants=1)
    out = tmp_path / "export"
    export_to_directory(db_session, ExportRequest(study_id=study.study_id), out)
    package = json.loads((out / "datapackage.json").read_text(encoding="utf-8"))
    resource = next(r for r in package["resources"] if r["name"] == "interactions")
    fields = {f["name"]: f for f in resource["schema"]["fields"]}
    assert fields["sync_lag_s"]["type"] == "number"
    assert fields["sync_lag_s"]["unit"] == "s"
    assert fields["sync_check"]["constraints"]["enum"] == ["ok", "failed"]
    assert "not_computed" in fields["sync_missing"]["constraints"]["enum"]
    codebook = next(p for p in out.iterdir() if p.name.startswith("codebook"))
    text = codebook.read_text(encoding="utf-8")
    assert "mimicry_r" in text
    assert "surrogate-corrected" in text
