"""Writers that turn row iterators into files, one batch at a time.

Every writer is a generator: it writes a batch to the binary stream it was given and
yields, so a caller streaming a zip to the browser can forward the bytes produced so far
(memory stays bounded by one batch, whatever the export's size).
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Collection, Iterable, Iterator, Mapping
from datetime import UTC, datetime
from itertools import islice
from typing import IO, TYPE_CHECKING, Any

import pyarrow as pa
import pyarrow.parquet as pq

from chameleons.backend.export import frames
from chameleons.backend.export.columns import Column, TableSpec

if TYPE_CHECKING:  # pandas is imported where it is used: the CLI starts faster
    import pandas as pd

Row = dict[str, Any]
BATCH_ROWS = 1000

_ARROW_TYPES = {
    "string": pa.string(),
    "integer": pa.int64(),
    "number": pa.float64(),
    "boolean": pa.bool_(),
    "datetime": pa.timestamp("ms", tz="UTC"),
}


def _batches(rows: Iterable[Row]) -> Iterator[list[Row]]:
    iterator = iter(rows)
    while batch := list(islice(iterator, BATCH_ROWS)):
        yield batch


# OWASP "CSV Injection" and ASVS 1.2.10: a spreadsheet runs a cell that starts with one of
# these as a formula; a leading ' makes it text (Excel, LibreOffice and Sheets hide it).
FORMULA_TRIGGERS = ("=", "+", "-", "@", "\t", "\r", "\0")


def neutralise(text: str) -> str:
    """``text`` as a spreadsheet shows it but never evaluates it."""
    return "'" + text if text.startswith(FORMULA_TRIGGERS) else text


def csv_cell(value: Any) -> str:
    """Cells R and pandas read without options: empty = missing, true/false, full floats."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def write_csv(
    stream: IO[bytes],
    columns: list[str],
    rows: Iterable[Row],
    counter: list[int],
    text_columns: Iterable[str] = (),
) -> Iterator[None]:
    """CSV; cells of ``text_columns`` that a spreadsheet would run as formulas are
    neutralised (pass none for raw output, e.g. ``chameleons export --raw-csv``)."""
    guarded = frozenset(text_columns)
    text = io.TextIOWrapper(stream, encoding="utf-8", newline="", write_through=True)
    try:
        writer = csv.writer(text, lineterminator="\n")
        writer.writerow(columns)
        for batch in _batches(rows):
            writer.writerows(
                [_cell(row.get(name), name in guarded) for name in columns] for row in batch
            )
            counter[0] += len(batch)
            yield
    finally:
        text.detach()  # the caller owns (and closes) the binary stream


def _cell(value: Any, guarded: bool) -> str:
    cell = csv_cell(value)
    return neutralise(cell) if guarded and isinstance(value, str) else cell


def write_json(
    stream: IO[bytes], columns: list[str], rows: Iterable[Row], counter: list[int]
) -> Iterator[None]:
    """A JSON array of objects with the table's columns, in order."""
    stream.write(b"[")
    first = True
    for batch in _batches(rows):
        for row in batch:
            record = {name: row.get(name) for name in columns}
            stream.write(
                (b"\n" if first else b",\n") + json.dumps(record, ensure_ascii=False).encode()
            )
            first = False
        counter[0] += len(batch)
        yield
    stream.write(b"\n]\n")


def arrow_schema(columns: tuple[Column, ...]) -> pa.Schema:
    return pa.schema([pa.field(c.name, _ARROW_TYPES[c.type]) for c in columns])


def _arrow_array(series: pd.Series, kind: pa.DataType) -> pa.Array:
    if pa.types.is_timestamp(kind):
        # Naive UTC values, then the zone: pandas warns on zone-aware values to arrow.
        naive = series.dt.tz_convert(None).to_numpy()
        return pa.array(naive, type=pa.timestamp("ms")).cast(kind)
    return pa.Array.from_pandas(series, type=kind)


def write_parquet(
    stream: IO[bytes], table: TableSpec, rows: Iterable[Row], counter: list[int]
) -> Iterator[None]:
    schema = arrow_schema(table.columns)
    with pq.ParquetWriter(stream, schema) as writer:
        for batch in _batches(rows):
            # The typed frame of the batch (one definition of the types, see frames.py).
            data = frames.frame(table, batch)
            arrays = [_arrow_array(data[f.name], f.type) for f in schema]
            writer.write_table(pa.Table.from_arrays(arrays, schema=schema))
            counter[0] += len(batch)
            yield
        if counter[0] == 0:
            writer.write_table(schema.empty_table())


def write_xlsx(
    stream: IO[bytes],
    sheets: list[tuple[str, list[str], Iterable[Row]]],
    time_columns: Mapping[str, Collection[str]] | None = None,
) -> Iterator[None]:
    """One workbook, one sheet per table.

    The columns named in ``time_columns[sheet]`` (ISO 8601 text in the rows) become real
    Excel date-times, in UTC: Excel has no time zones, so the aware time is converted to UTC
    and stored without one (the codebook says the column is UTC). Every string is written
    as a text cell (``t="inlineStr"``, never a formula): openpyxl would otherwise store a
    string starting with ``=`` as a live formula."""
    from openpyxl import Workbook  # imported here: only Excel exports need it

    workbook = Workbook(write_only=True)
    for title, columns, rows in sheets:
        sheet = workbook.create_sheet(title=title[:31])
        sheet.append([_text_cell(sheet, name) for name in columns])
        times = set((time_columns or {}).get(title, ()))
        for batch in _batches(rows):
            for row in batch:
                sheet.append(
                    [
                        _time_cell(sheet, row.get(name))
                        if name in times
                        else _xlsx_value(sheet, row.get(name))
                        for name in columns
                    ]
                )
            yield
    workbook.save(stream)
    yield


XLSX_TIME_FORMAT = "yyyy-mm-dd hh:mm:ss.000"


def utc_naive(value: Any) -> datetime | None:
    """An ISO 8601 time (or datetime) as a naive datetime in UTC; None when empty. A
    naive input is taken as UTC already (SQLite returns stored UTC times without a zone)."""
    if value is None or value == "":
        return None
    moment = value if isinstance(value, datetime) else datetime.fromisoformat(str(value))
    if moment.tzinfo is not None:
        moment = moment.astimezone(UTC).replace(tzinfo=None)
    return moment


def _time_cell(sheet: Any, value: Any) -> Any:
    from openpyxl.cell import WriteOnlyCell

    moment = utc_naive(value)
    if moment is None:
        return None
    cell = WriteOnlyCell(sheet, value=moment)
    cell.number_format = XLSX_TIME_FORMAT
    return cell


def _text_cell(sheet: Any, text: str) -> Any:
    from openpyxl.cell import WriteOnlyCell

    cell = WriteOnlyCell(sheet, value=text)
    cell.data_type = "s"  # openpyxl made "=..." a formula and "#N/A" an error: text it is
    return cell


def _xlsx_value(sheet: Any, value: Any) -> Any:
    return _text_cell(sheet, value) if isinstance(value, str) else value
