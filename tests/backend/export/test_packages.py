"""The bundle as a Frictionless Data Package (validated by the frictionless library), and
the SPSS/Stata files (read back with pyreadstat and compared with the CSV files)."""

from __future__ import annotations

import csv
import json
import math
from datetime import UTC, datetime
from pathlib import Path

import pyreadstat
import pytest
from fastapi.testclient import TestClient
from frictionless import Package
from sqlalchemy import Engine
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.columns import TABLE_NAMES, TableSpec, table_specs
from chameleons.backend.export.frames import records, table_frame
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.export.statfiles import value_labels
from tests.support.factories import PopulatedStudy, populate


@pytest.fixture
def exported(db_session: DbSession, tmp_path: Path) -> tuple[PopulatedStudy, Path]:
    data = populate(db_session, 12, seed=2)
    db_session.commit()
    export_to_directory(db_session, ExportRequest(formats=("csv", "sav", "dta")), tmp_path)
    return data, tmp_path


def read_csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def validate(folder: Path) -> list[str]:
    report = Package(str(folder / "datapackage.json")).validate()
    return [f"{e[0]} {e[1]}" for e in report.flatten(["type", "note"])]


def test_the_bundle_is_a_valid_frictionless_data_package(
    exported: tuple[PopulatedStudy, Path],
) -> None:
    data, folder = exported
    assert validate(folder) == []
    package = json.loads((folder / "datapackage.json").read_text())
    assert [r["name"] for r in package["resources"]] == list(TABLE_NAMES)
    scores = next(r for r in package["resources"] if r["name"] == "scores")
    fields = {f["name"]: f for f in scores["schema"]["fields"]}
    assert fields["condition"]["constraints"]["enum"] == ["still", "natural", "copy"]
    assert fields["trust"]["constraints"] == {"minimum": 1, "maximum": 7}
    assert fields["trust"]["unit"] == "scale points"
    assert fields["accepted"]["type"] == "integer"
    codebook = {
        (r["table"], r["column"]): r["description"] for r in read_csv(folder / "codebook.csv")
    }
    assert fields["trust"]["description"] == codebook[("scores", "trust")]
    suggestions = next(r for r in package["resources"] if r["name"] == "suggestions")
    assert suggestions["schema"]["primaryKey"] == ["participant", "session", "position", "index"]
    assert package["study_config_hash"] == data.spec.content_hash


def _rewrite(path: Path, change: dict[str, str], row: int = 0) -> None:
    rows = read_csv(path)
    rows[row].update(change)
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)


def test_a_value_outside_its_allowed_set_or_a_broken_reference_fails_validation(
    exported: tuple[PopulatedStudy, Path],
) -> None:
    _, folder = exported
    _rewrite(folder / "scores.csv", {"condition": "Copy"})  # labels are case-sensitive
    errors = validate(folder)
    assert any("constraint-error" in e and "enum" in e for e in errors), errors
    _rewrite(folder / "scores.csv", {"condition": "copy"})
    _rewrite(folder / "scores.csv", {"trust": "9"})
    assert any("constraint-error" in e for e in validate(folder))
    _rewrite(folder / "scores.csv", {"trust": "5"})
    assert validate(folder) == []
    participants = read_csv(folder / "participants.csv")
    with (folder / "participants.csv").open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(participants[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(participants[1:])  # P001 is gone; their rows elsewhere still refer
    assert any("foreign-key" in e for e in validate(folder))


def _expected(table: str, column: str, text: str, labels: dict[str, dict[str, str]]) -> object:
    """What the SPSS/Stata file holds for a CSV cell, with value labels applied."""
    spec = next(t for t in table_specs_cache if t.name == table)
    kind = next(c.type for c in spec.columns if c.name == column)
    if kind == "boolean":  # 0/1 labelled false/true
        return None if text == "" else text
    if kind in {"integer", "number"}:
        return None if text == "" else float(text)
    if kind == "datetime":
        return (
            None
            if text == ""
            else datetime.fromisoformat(text).astimezone(UTC).replace(tzinfo=None)
        )
    if column in labels:
        return None if text == "" else labels[column].get(text, text)
    return text


table_specs_cache: list[TableSpec] = []


@pytest.mark.parametrize("fmt", ["sav", "dta"])
def test_spss_and_stata_files_hold_the_csv_with_labels(
    exported: tuple[PopulatedStudy, Path], fmt: str
) -> None:
    data, folder = exported
    table_specs_cache[:] = table_specs(data.spec)
    labels = value_labels(data.spec)
    reader = pyreadstat.read_sav if fmt == "sav" else pyreadstat.read_dta
    for table in table_specs_cache:
        frame, meta = reader(str(folder / f"{table.name}.{fmt}"))
        rows = read_csv(folder / f"{table.name}.csv")
        assert list(frame.columns) == table.column_names
        assert len(frame) == len(rows), table.name
        value_formats = meta.variable_value_labels
        for column in table.column_names:
            assert meta.column_names_to_labels[column], f"{table.name}.{column}: no label"
            for index, row in enumerate(rows):
                stored = frame[column].iloc[index]
                if column in value_formats and column not in {"value"}:
                    stored = value_formats[column].get(stored, stored)
                if isinstance(stored, float) and math.isnan(stored):
                    stored = None
                if hasattr(stored, "to_pydatetime"):
                    stored = stored.to_pydatetime()
                expected = _expected(table.name, column, row[column], labels)
                if isinstance(expected, datetime) and stored is not None:
                    assert abs((stored - expected).total_seconds()) < 0.002, (table.name, column)
                    continue
                if expected is None and stored == "":
                    continue  # Stata and SPSS have no missing text: empty
                assert stored == expected, (table.name, column, index, stored, expected)
    # The labels a Stata or SPSS user sees.
    suggestions, meta = reader(str(folder / f"suggestions.{fmt}"), apply_value_formats=True)
    assert set(suggestions["condition"]) <= {"Still", "Natural movement", "Copy"}
    names = {item.name for task in data.spec.tasks for item in task.items}
    assert set(suggestions["item"]) <= names
    _, answers = reader(str(folder / f"questionnaire.{fmt}"))
    assert answers.variable_value_labels["value"][1.0].startswith("1 = ")
    assert answers.variable_value_labels["reverse_keyed"] == {0.0: "false", 1.0: "true"}


def test_frames_are_typed_by_the_codebook(db_session: DbSession) -> None:
    from chameleons.backend.export.rows import suggestion_rows
    from chameleons.backend.models import Study

    data = populate(db_session, 2, seed=1)
    study = db_session.get(Study, data.study_id)
    assert study is not None
    table = next(t for t in table_specs(data.spec) if t.name == "suggestions")
    frame = table_frame(table, suggestion_rows(db_session, study, False))
    assert str(frame["position"].dtype) == "Int64"
    assert str(frame["accepted"].dtype) == "boolean"
    assert str(frame["proposed_at"].dtype) == "datetime64[ms, UTC]"
    assert str(frame["item"].dtype) == "string"
    first = records(frame)[0]
    assert isinstance(first["position"], int)
    assert first["accepted"] in (True, False)
    assert len(records(frame)) == len(frame) == 18


def test_export_page_and_zip_offer_spss_and_stata(client: TestClient, engine: Engine) -> None:
    import io
    import zipfile

    from chameleons.backend.db import build_sessionmaker, session_scope
    from tests.backend.test_auth import add_user, login

    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, 2)
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    page = client.get(f"/pi/export?study={data.study_id}").text
    assert 'value="sav"' in page
    assert 'value="dta"' in page
    bundle = client.get(f"/api/pi/export.zip?study={data.study_id}&format=sav&format=dta")
    names = set(zipfile.ZipFile(io.BytesIO(bundle.content)).namelist())
    assert {"scores.sav", "scores.dta", "datapackage.json", "analysis.R"} <= names
