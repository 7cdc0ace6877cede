"""data.xlsx: every time column holds real Excel date-times (UTC, no zone), equal to the
CSV's ISO times to the millisecond; empty times stay empty; the codebook says UTC."""

from __future__ import annotations

import csv
from datetime import UTC, datetime, timedelta, timezone
from pathlib import Path

from openpyxl import load_workbook
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.columns import table_specs
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.export.writers import utc_naive
from tests.support.factories import populate


def test_time_columns_are_excel_datetimes_in_utc(db_session: DbSession, tmp_path: Path) -> None:
    data = populate(db_session, 3)
    db_session.commit()
    export_to_directory(db_session, ExportRequest(formats=("csv", "xlsx")), tmp_path)
    workbook = load_workbook(tmp_path / "data.xlsx")
    checked = 0
    for table in table_specs(data.spec):
        times = [c.name for c in table.columns if c.type == "datetime"]
        with (tmp_path / f"{table.name}.csv").open(newline="", encoding="utf-8") as handle:
            rows = list(csv.DictReader(handle))
        sheet = workbook[table.name]
        header = [cell.value for cell in sheet[1]]
        for number, row in enumerate(rows, start=2):
            for name in times:
                cell = sheet.cell(row=number, column=header.index(name) + 1)
                if not row[name]:
                    assert cell.value is None
                    continue
                assert isinstance(cell.value, datetime), (table.name, name, cell.value)
                assert cell.value.tzinfo is None
                assert cell.is_date
                expected = datetime.fromisoformat(row[name]).astimezone(UTC).replace(tzinfo=None)
                assert abs(cell.value - expected) < timedelta(milliseconds=1)
                checked += 1
    assert checked > 50  # the populated study has times in every table that has them
    codebook = list(workbook["codebook"].iter_rows(values_only=True))
    header = list(codebook[0])
    started = next(r for r in codebook if r[header.index("column")] == "started_at")
    assert "in data.xlsx an Excel date-time in UTC" in str(started[header.index("description")])
    workbook.close()


def test_aware_times_become_utc_naive() -> None:
    plus_two = timezone(timedelta(hours=2))
    assert utc_naive("2026-03-02T11:00:00.250+02:00") == datetime(2026, 3, 2, 9, 0, 0, 250000)
    assert utc_naive(datetime(2026, 3, 2, 11, tzinfo=plus_two)) == datetime(2026, 3, 2, 9)
    assert utc_naive("2026-03-02T09:00:00") == datetime(2026, 3, 2, 9)  # naive: UTC already
    assert utc_naive("") is None
    assert utc_naive(None) is None
