"""The export as R and pandas users meet it: files read without cleaning, on both databases."""

from __future__ import annotations

import csv
import io
import json
import zipfile
from collections import Counter
from datetime import datetime, timedelta
from pathlib import Path

import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest
from fastapi.testclient import TestClient
from openpyxl import load_workbook
from sqlalchemy import Engine
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.export.columns import TABLE_NAMES, table_specs
from chameleons.backend.export.selection import StudyNotFoundError
from chameleons.backend.export.service import ExportRequest, export_to_directory
from tests.backend.test_auth import add_user, login
from tests.support.factories import PopulatedStudy, populate

KEYS = {
    "participants": ("participant",),
    "interactions": ("participant", "session", "position"),
    "suggestions": ("participant", "session", "position", "index"),
    "questionnaire": ("participant", "session", "position", "questionnaire", "item"),
    "scores": ("participant", "condition"),
    "events": ("event",),
    "booth_checks": ("session", "checked_at"),
}
TIME_COLUMNS = {
    "participants": ("consent_at", "started_at", "completed_at"),
    "interactions": ("started_at", "ended_at"),
    "suggestions": ("proposed_at", "decided_at"),
    "questionnaire": ("answered_at",),
    "events": ("server_time",),
    "booth_checks": ("checked_at",),
}


def read_csv(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    with path.open(newline="", encoding="utf-8") as handle:
        reader = csv.DictReader(handle)
        return list(reader.fieldnames or []), list(reader)


@pytest.fixture
def populated(db_session: DbSession, tmp_path: Path) -> PopulatedStudy:
    data = populate(db_session, 12, rehearsals=2, free_rows=1, recordings_dir=tmp_path / "rec")
    db_session.commit()
    return data


def test_every_table_reads_without_cleaning(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    out = tmp_path / "export"
    export_to_directory(db_session, ExportRequest(), out)
    specs = {spec.name: spec for spec in table_specs(populated.spec)}
    expected_rows = {"participants": 12, "interactions": 36, "suggestions": 108, "scores": 36}
    for name in TABLE_NAMES:
        header, rows = read_csv(out / f"{name}.csv")
        assert header == specs[name].column_names, f"{name}: unstable columns"
        assert header[0], "no index column"
        assert not header[0].startswith("Unnamed"), "no index column"
        if name in expected_rows:
            assert len(rows) == expected_rows[name], name
        keys = [tuple(row[k] for k in KEYS[name]) for row in rows]
        assert len(keys) == len(set(keys)), f"{name}: more than one row per observation"
        assert all(row["participant"] in populated.codes[:12] for row in rows), "rehearsal leaked"
        for column in TIME_COLUMNS.get(name, ()):
            for row in rows:
                parsed = datetime.fromisoformat(row[column])
                assert parsed.utcoffset() == timedelta(0), f"{name}.{column} not UTC"
        # Arrow's CSV reader (what pandas' pyarrow engine uses) infers types unaided.
        table = pacsv.read_csv(out / f"{name}.csv")
        assert table.column_names == header
    scores = pacsv.read_csv(out / "scores.csv")
    assert str(scores.schema.field("accepted").type) == "int64"
    assert str(scores.schema.field("credibility").type) == "double"
    interactions = pacsv.read_csv(out / "interactions.csv")
    assert str(interactions.schema.field("deviation").type) == "bool"
    assert "timestamp" in str(interactions.schema.field("started_at").type)


def test_questionnaire_is_long_with_reverse_keying_and_versions(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    export_to_directory(db_session, ExportRequest(), tmp_path)
    _, rows = read_csv(tmp_path / "questionnaire.csv")
    # per person: 3 interactions' questionnaires, 3 questions before, 4 final questions
    assert len(rows) == 12 * (3 * (12 + 10 + 6 + 1) + 3 + 4)
    reliable = [r for r in rows if (r["questionnaire"], r["item"]) == ("credibility", "reliable")]
    assert reliable
    assert all(r["reverse_keyed"] == "true" for r in reliable)
    assert all(int(r["scored_value"]) == 8 - int(r["value"]) for r in reliable)
    final = [r for r in rows if r["position"] == "0"]
    assert len(final) == 48
    assert all(r["condition"] == "" for r in final)
    assert all(r["text"] for r in final if r["item"] != "imitating_robot")
    named = [r for r in final if r["item"] == "imitating_robot"]
    assert all(r["named_condition"] in ("still", "natural", "copy") for r in named)
    assert {r["position"] for r in rows if r["questionnaire"] == "demographics"} == {"-1"}
    assert {r["version"] for r in rows} == {"rau2009-v1", "final-v2", "demographics-v1"}


def test_rehearsals_only_when_asked(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    export_to_directory(db_session, ExportRequest(include_rehearsal=True), tmp_path)
    _, participants = read_csv(tmp_path / "participants.csv")
    assert [p["participant"] for p in participants] == populated.codes
    assert [p["rehearsal"] for p in participants][-2:] == ["true", "true"]
    metadata = json.loads((tmp_path / "metadata.json").read_text())
    assert metadata["include_rehearsal"] is True
    assert metadata["rows"]["participants"] == 14


def test_codebook_config_and_version(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    from chameleons import __version__

    export_to_directory(db_session, ExportRequest(), tmp_path)
    _, book = read_csv(tmp_path / "codebook.csv")
    described = {(row["table"], row["column"]) for row in book}
    for name in TABLE_NAMES:
        header, _ = read_csv(tmp_path / f"{name}.csv")
        assert {(name, column) for column in header} <= described
    identifying = {(r["table"], r["column"]) for r in book if r["possibly_identifying"] == "true"}
    assert ("questionnaire", "text") in identifying
    assert all(row["description"] for row in book)
    config = json.loads((tmp_path / "study_config.json").read_text())
    assert config == populated.spec.config
    metadata = json.loads((tmp_path / "metadata.json").read_text())
    assert metadata["study_config_hash"] == populated.spec.content_hash
    assert metadata["software_version"] == __version__
    assert metadata["rows"]["questionnaire"] == 12 * (87 + 3 + 4)


def test_parquet_json_and_excel_hold_the_same_rows_as_csv(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    request = ExportRequest(formats=("csv", "parquet", "json", "xlsx"))
    export_to_directory(db_session, request, tmp_path)
    workbook = load_workbook(tmp_path / "data.xlsx", read_only=True)
    for name in TABLE_NAMES:
        header, rows = read_csv(tmp_path / f"{name}.csv")
        parquet = pq.read_table(tmp_path / f"{name}.parquet")
        assert parquet.column_names == header
        assert parquet.num_rows == len(rows)
        records = json.loads((tmp_path / f"{name}.json").read_text())
        assert len(records) == len(rows)
        assert list(records[0]) == header
        sheet = list(workbook[name].iter_rows(values_only=True))
        assert list(sheet[0]) == header
        assert len(sheet) == len(rows) + 1
    scores_pq = pq.read_table(tmp_path / "scores.parquet").to_pylist()
    _, scores_csv = read_csv(tmp_path / "scores.csv")
    assert [r["credibility"] for r in scores_pq] == [float(r["credibility"]) for r in scores_csv]
    started = pq.read_table(tmp_path / "interactions.parquet").column("started_at")
    assert str(started.type) == "timestamp[ms, tz=UTC]"
    workbook.close()


def test_unknown_study_is_a_clear_error(db_session: DbSession, tmp_path: Path) -> None:
    with pytest.raises(StudyNotFoundError, match="no study"):
        export_to_directory(db_session, ExportRequest(), tmp_path)
    with pytest.raises(StudyNotFoundError, match="id 999"):
        export_to_directory(db_session, ExportRequest(study_id=999), tmp_path)


def test_zip_download_streams_the_bundle(client: TestClient, engine: Engine) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        populate(db, 3, rehearsals=1)
    add_user(engine, "pia", "correct horse", "pi")
    assert client.get("/api/pi/export.zip").status_code == 401
    login(client, "pia", "correct horse")
    response = client.get("/api/pi/export.zip", params={"format": ["parquet", "xlsx"]})
    assert response.status_code == 200
    assert response.headers["content-type"] == "application/zip"
    assert response.headers["content-disposition"].startswith("attachment; filename=")
    archive = zipfile.ZipFile(io.BytesIO(response.content))
    names = set(archive.namelist())
    assert {f"{t}.csv" for t in TABLE_NAMES} <= names
    assert {f"{t}.parquet" for t in TABLE_NAMES} <= names
    assert {"data.xlsx", "codebook.csv", "study_config.json", "metadata.json"} <= names
    participants = archive.read("participants.csv").decode().splitlines()
    assert len(participants) == 1 + 3
    assert client.get("/api/pi/export.zip", params={"study": 999}).status_code == 404


def test_zip_download_refuses_wizards(client: TestClient, engine: Engine) -> None:
    add_user(engine, "wiz", "right password", "wizard")
    login(client, "wiz", "right password")
    assert client.get("/api/pi/export.zip").status_code == 403


def test_a_large_export_streams_in_bounded_chunks(engine: Engine) -> None:
    """Many events: the zip arrives as many chunks, none holding the whole table."""
    from sqlalchemy import insert

    from chameleons.backend.export.service import stream_zip
    from chameleons.backend.models import Event

    factory = build_sessionmaker(engine)
    with session_scope(factory) as db:
        data = populate(db, 1)
        rows = [
            {
                "study_id": data.study_id,
                "session_id": data.session_ids[0],
                "kind": "telemetry.sample",
                "source": "worker",
                "payload": {"n": n, "padding": "x" * 40},
            }
            for n in range(10_000)
        ]
        db.execute(insert(Event), rows)
    _, chunks = stream_zip(factory, ExportRequest())
    received = list(chunks)
    archive = zipfile.ZipFile(io.BytesIO(b"".join(received)))
    events_csv = archive.read("events.csv")
    assert events_csv.count(b"\n") > 10_000
    assert len(received) > 10
    assert max(len(chunk) for chunk in received) < len(events_csv) / 4


def test_what_natural_replayed_and_which_way_suggestions_moved_are_exported(
    db_session: DbSession, tmp_path: Path
) -> None:
    from sqlalchemy import select

    from chameleons.backend.models import Interaction, Suggestion

    data = populate(db_session, 3)
    interactions = list(db_session.scalars(select(Interaction).order_by(Interaction.id)))
    natural = next(i for i in interactions if i.condition == "natural")
    natural.natural_source, natural.natural_recording = "clip", "clip demo-natural"
    down = db_session.scalars(select(Suggestion).order_by(Suggestion.id)).first()
    assert down is not None
    down.from_rank, down.to_rank = 1, 4
    db_session.commit()
    export_to_directory(db_session, ExportRequest(), tmp_path)
    _, rows = read_csv(tmp_path / "interactions.csv")
    by_key = {(r["session"], r["position"]): r for r in rows}
    row = by_key[(str(natural.session_id), str(natural.position))]
    assert (row["behaviour"], row["natural_source"], row["natural_recording"]) == (
        "natural", "clip", "clip demo-natural",
    )  # fmt: skip
    others = [r for r in rows if r is not row]
    assert all(r["natural_source"] == "" and r["natural_recording"] == "" for r in others)
    assert {r["behaviour"] for r in rows} == {"still", "natural", "copy"}
    _, suggestions = read_csv(tmp_path / "suggestions.csv")
    directions = Counter(r["direction"] for r in suggestions)
    assert directions == {"down": 1, "up": len(suggestions) - 1}
    codebook = (tmp_path / "codebook.csv").read_text("utf-8")
    assert "natural_source" in codebook
    assert "clip, yoked, synthetic" in codebook
    assert data.study_id


def test_booth_checks_are_exported_with_their_figures_and_in_the_codebook(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    export_to_directory(db_session, ExportRequest(formats=("csv",)), tmp_path)
    header, rows = read_csv(tmp_path / "booth_checks.csv")
    assert len(rows) == 12  # one check before each participant (rehearsals not exported)
    first = rows[0]
    assert (first["passed"], first["copy_status"], first["speech_status"]) == (
        "true", "pass", "pass",
    )  # fmt: skip
    assert (float(first["copy_delay_s"]), float(first["measured_delay_s"])) == (4.0, 4.02)
    assert float(first["speech_start_ms"]) == 180.0
    _, book = read_csv(tmp_path / "codebook.csv")
    described = {r["column"] for r in book if r["table"] == "booth_checks"}
    assert set(header) == described
    assert "measured_delay_s" in described


def test_a_booth_check_run_without_a_session_is_exported_with_empty_participant_and_session(
    db_session: DbSession, populated: PopulatedStudy, tmp_path: Path
) -> None:
    from chameleons.backend.models import BoothCheck

    steps = [{"id": "copy", "status": "fail", "value": "", "figures": {}}]
    between = BoothCheck(booth="booth-4", study_id=populated.study_id, session_id=None,
                         passed=False, steps=steps, copy_delay_s=4.0)  # fmt: skip
    no_study = BoothCheck(booth="booth-5", study_id=None, session_id=None, passed=True, steps=[])
    db_session.add_all([between, no_study])
    db_session.commit()
    export_to_directory(db_session, ExportRequest(formats=("csv",)), tmp_path)
    _, rows = read_csv(tmp_path / "booth_checks.csv")
    assert len(rows) == 13  # the 12 before participants, and the one between them
    alone = [r for r in rows if r["booth"] == "booth-4"]
    assert len(alone) == 1
    assert (alone[0]["participant"], alone[0]["session"]) == ("", "")
    assert (alone[0]["copy_status"], alone[0]["passed"]) == ("fail", "false")
    assert all(r["booth"] != "booth-5" for r in rows)  # no study: in no study's export
    _, book = read_csv(tmp_path / "codebook.csv")
    session = next(r for r in book if r["table"] == "booth_checks" and r["column"] == "session")
    assert "empty: run without a session" in session["description"]
