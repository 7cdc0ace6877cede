"""The manifest file format: one CSV per actor, edited by a lab in a spreadsheet.

Reading keeps each record's starting line (the header is line 1; a quoted cell may span
lines) so every problem can be reported as ``file:line``.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from chameleons.locations import MANIFEST_NAME as MANIFEST_NAME

ACTOR_PROFILE_NAME = "actor.yaml"
MANIFEST_COLUMNS: tuple[str, ...] = (
    "id", "stage", "group", "text", "task", "item", "other_item", "robot_name", "audio",
    "lipsync",
)  # fmt: skip
# Without these a row cannot be understood; the others may be left out of the header.
REQUIRED_COLUMNS: tuple[str, ...] = ("id", "stage", "group", "text")


@dataclass(frozen=True, slots=True)
class ManifestRow:
    line: int
    cells: Mapping[str, str]  # column -> stripped cell text ("" when empty or absent)
    extra_cells: int = 0  # cells beyond the header (a stray comma in a spreadsheet)


@dataclass(frozen=True, slots=True)
class ManifestTable:
    header: tuple[str, ...]
    rows: tuple[ManifestRow, ...]


class ManifestSyntaxError(ValueError):
    """Broken CSV quoting; ``line`` is where the broken record starts."""

    def __init__(self, line: int, message: str) -> None:
        super().__init__(message)
        self.line = line


def read_manifest(path: Path) -> ManifestTable:
    """Parse ``path`` (UTF-8, an Excel BOM is fine).

    Raises OSError, UnicodeError, or ManifestSyntaxError for broken quoting.
    """
    header: tuple[str, ...] = ()
    rows: list[ManifestRow] = []
    with path.open(encoding="utf-8-sig", newline="") as handle:
        reader = csv.reader(handle, strict=True)
        previous_end = 0
        records = iter(reader)
        while True:
            start = previous_end + 1
            try:
                record = next(records)
            except StopIteration:
                break
            except csv.Error as error:
                raise ManifestSyntaxError(start, f"broken quoting: {error}") from error
            previous_end = reader.line_num
            if not header:
                header = tuple(cell.strip().lower() for cell in record)
            elif any(cell.strip() for cell in record):  # skip the ",,,," rows of spreadsheets
                rows.append(_row(header, record, start))
    return ManifestTable(header, tuple(rows))


def _row(header: tuple[str, ...], record: list[str], line: int) -> ManifestRow:
    cells = {name: value.strip() for name, value in zip(header, record, strict=False)}
    return ManifestRow(line, cells, max(0, len(record) - len(header)))


def manifest_text(rows: Iterable[Mapping[str, str | None]]) -> str:
    """The CSV text of a manifest: header, then rows in column order (None/missing = empty)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(MANIFEST_COLUMNS)
    for row in rows:
        writer.writerow([row.get(column) or "" for column in MANIFEST_COLUMNS])
    return buffer.getvalue()


def write_manifest(path: Path, rows: Iterable[Mapping[str, str | None]]) -> None:
    """Write ``manifest_text(rows)`` to ``path`` (UTF-8), creating the actor folder."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(manifest_text(rows), encoding="utf-8", newline="")
