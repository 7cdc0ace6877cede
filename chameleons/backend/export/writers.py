"""Writers that turn row iterators into files, one batch at a time.

Every writer is a generator: it writes a batch to the binary stream it was given and
yields, so a caller streaming a zip to the browser can forward the bytes produced so far
(memory stays bounded by one batch, whatever the export's size).
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterable, Iterator
from datetime import datetime
from itertools import islice
from typing import IO, Any

import pyarrow as pa
import pyarrow.parquet as pq

from chameleons.backend.export.columns import Column, TableSpec

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
    stream: IO[bytes], columns: list[str], rows: Iterable[Row], counter: list[int]
) -> Iterator[None]:
    text = io.TextIOWrapper(stream, encoding="utf-8", newline="", write_through=True)
    try:
        writer = csv.writer(text, lineterminator="\n")
        writer.writerow(columns)
        for batch in _batches(rows):
            writer.writerows([csv_cell(row.get(name)) for name in columns] for row in batch)
            counter[0] += len(batch)
            yield
    finally:
        text.detach()  # the caller owns (and closes) the binary stream


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


def _arrow_value(column: Column, value: Any) -> Any:
    if column.type == "datetime" and isinstance(value, str):
        return datetime.fromisoformat(value)
    return value


def write_parquet(
    stream: IO[bytes], table: TableSpec, rows: Iterable[Row], counter: list[int]
) -> Iterator[None]:
    schema = arrow_schema(table.columns)
    with pq.ParquetWriter(stream, schema) as writer:
        for batch in _batches(rows):
            arrays = {
                c.name: [_arrow_value(c, row.get(c.name)) for row in batch] for c in table.columns
            }
            writer.write_table(pa.table(arrays, schema=schema))
            counter[0] += len(batch)
            yield
        if counter[0] == 0:
            writer.write_table(schema.empty_table())


def write_xlsx(
    stream: IO[bytes], sheets: list[tuple[str, list[str], Iterable[Row]]]
) -> Iterator[None]:
    """One workbook, one sheet per table (times stay ISO text: Excel has no time zones)."""
    from openpyxl import Workbook  # imported here: only Excel exports need it

    workbook = Workbook(write_only=True)
    for title, columns, rows in sheets:
        sheet = workbook.create_sheet(title=title[:31])
        sheet.append(columns)
        for batch in _batches(rows):
            for row in batch:
                sheet.append([row.get(name) for name in columns])
            yield
    workbook.save(stream)
    yield
