"""The export page's preview: the first rows of each table, exactly as the CSV has them
(the same row sources and column order), so the PI sees what the download holds."""

from __future__ import annotations

from dataclasses import dataclass
from itertools import islice

from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.columns import table_specs
from chameleons.backend.export.selection import resolve_study
from chameleons.backend.export.service import ExportPlan, ExportRequest, table_source
from chameleons.backend.export.writers import csv_cell
from chameleons.experiment.study import study_from_config

PREVIEW_ROWS = 5


@dataclass(frozen=True)
class TablePreview:
    name: str
    description: str
    columns: list[str]
    rows: list[list[str]]


def preview(
    db: DbSession, study_id: int, include_rehearsal: bool = False, limit: int = PREVIEW_ROWS
) -> list[TablePreview]:
    study = resolve_study(db, study_id)
    spec = study_from_config(study.config)
    plan = ExportPlan(study, spec, ExportRequest(study_id, include_rehearsal=include_rehearsal))
    tables = []
    for table in table_specs(spec):
        source = iter(table_source(db, plan, table.name)())
        try:
            rows = list(islice(source, limit))
        finally:
            close = getattr(source, "close", None)
            if close is not None:
                close()  # a generator stopped early: its database cursor closes now
        shown = [[csv_cell(row.get(name)) for name in table.column_names] for row in rows]
        tables.append(TablePreview(table.name, table.description, table.column_names, shown))
    return tables
