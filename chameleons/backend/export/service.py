"""Assemble an export: the tables in the asked formats, codebook, study config, metadata.

``export_to_directory`` writes files (the CLI); ``stream_zip`` yields a zip bundle chunk
by chunk (the browser download). Both use the same parts, so they contain the same data.
"""

from __future__ import annotations

import json
import tempfile
import zipfile
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any, Literal

from sqlalchemy.orm import Session as DbSession
from sqlalchemy.orm import sessionmaker

from chameleons import __version__
from chameleons.backend.export import rows as table_rows
from chameleons.backend.export import writers
from chameleons.backend.export.analysis_r import analysis_script
from chameleons.backend.export.booth_rows import booth_check_rows
from chameleons.backend.export.columns import (
    CODEBOOK_COLUMNS,
    LIST_SEPARATOR,
    TableSpec,
    codebook_rows,
    table_specs,
)
from chameleons.backend.export.datapackage import datapackage
from chameleons.backend.export.frames import table_frame
from chameleons.backend.export.provenance import provenance, provenance_codebook
from chameleons.backend.export.scoring import score_rows
from chameleons.backend.export.selection import resolve_study
from chameleons.backend.export.statfiles import StatFormat, write_statfile
from chameleons.backend.models import Study
from chameleons.experiment.model import Study as StudySpec
from chameleons.experiment.study import study_from_config
from chameleons.prompts.locations import REPOSITORY_PROMPTS

ExportFormat = Literal["csv", "parquet", "xlsx", "json", "sav", "dta"]
FORMATS: tuple[ExportFormat, ...] = ("csv", "parquet", "xlsx", "json", "sav", "dta")
Row = dict[str, Any]


@dataclass(frozen=True)
class ExportRequest:
    study_id: int | None = None
    formats: tuple[ExportFormat, ...] = ("csv",)
    include_rehearsal: bool = False
    # CSV text cells a spreadsheet would run as formulas get a leading ' (OWASP); raw_csv
    # writes them as stored (for R/pandas users who never open the files in a spreadsheet).
    raw_csv: bool = False
    # The prompts folder in use (for the catalogue versions); None: the repository's.
    prompts_dir: Path | None = None


@dataclass
class Part:
    """One file of the export; ``write`` writes it batch by batch (see :mod:`writers`)."""

    name: str
    write: Callable[[IO[bytes]], Iterator[None]]
    needs_seek: bool = False


@dataclass
class ExportPlan:
    study: Study
    spec: StudySpec
    request: ExportRequest
    parts: list[Part] = field(default_factory=list)
    row_counts: dict[str, list[int]] = field(default_factory=dict)

    def metadata(self) -> dict[str, Any]:
        return {
            "software": "mechanical-chameleons",
            "software_version": __version__,
            "exported_at": datetime.now(UTC).isoformat(timespec="seconds"),
            "study": {"id": self.study.id, "name": self.study.name},
            "study_config_hash": self.study.config_hash,
            **provenance(self.study, self.spec, self.request.prompts_dir or REPOSITORY_PROMPTS),
            "include_rehearsal": self.request.include_rehearsal,
            "formats": ["csv", *(f for f in self.request.formats if f != "csv")],
            "list_separator": LIST_SEPARATOR,
            "csv_formula_guard": not self.request.raw_csv,
            "missing_value": "empty cell (CSV), null (JSON, Parquet)",
            "rows": {name: count[0] for name, count in self.row_counts.items()},
        }


def table_source(db: DbSession, plan: ExportPlan, name: str) -> Callable[[], Iterable[Row]]:
    study, spec, rehearsal = plan.study, plan.spec, plan.request.include_rehearsal
    sources: dict[str, Callable[[], Iterable[Row]]] = {
        "participants": lambda: table_rows.participant_rows(db, study, rehearsal),
        "interactions": lambda: table_rows.interaction_rows(db, study, spec, rehearsal),
        "suggestions": lambda: table_rows.suggestion_rows(db, study, rehearsal),
        "questionnaire": lambda: table_rows.questionnaire_rows(db, study, spec, rehearsal),
        "scores": lambda: score_rows(db, study, spec, rehearsal),
        "events": lambda: table_rows.event_rows(db, study, rehearsal),
        "booth_checks": lambda: booth_check_rows(db, study, rehearsal),
    }
    return sources[name]


def _bytes_part(name: str, produce: Callable[[], bytes]) -> Part:
    def write(stream: IO[bytes]) -> Iterator[None]:
        stream.write(produce())
        yield

    return Part(name, write)


def plan_export(db: DbSession, request: ExportRequest) -> ExportPlan:
    study = resolve_study(db, request.study_id)
    spec = study_from_config(study.config)
    plan = ExportPlan(study, spec, request)
    specs = table_specs(spec)
    for table in specs:
        _add_table_parts(db, plan, table)
    if "xlsx" in request.formats:
        plan.parts.append(_xlsx_part(db, plan, specs))
    book = codebook_rows(specs)
    if not request.raw_csv:
        for entry in book:
            if entry["type"] == "string":
                entry["description"] = f"{entry['description']} {CSV_GUARD_NOTE}"
    book += provenance_codebook()  # metadata.json keys, not CSV cells
    plan.parts.append(
        Part(
            "codebook.csv",
            lambda s: writers.write_csv(
                s, list(CODEBOOK_COLUMNS), book, [0], _guarded(request, CODEBOOK_COLUMNS)
            ),
        )
    )
    config = json.dumps(study.config, indent=2, sort_keys=True, ensure_ascii=False) + "\n"
    plan.parts.append(_bytes_part("study_config.json", config.encode))
    script = analysis_script(study, spec, specs)
    plan.parts.append(_bytes_part("analysis.R", script.encode))
    package = json.dumps(datapackage(study, spec, specs), indent=2, ensure_ascii=False) + "\n"
    plan.parts.append(_bytes_part("datapackage.json", package.encode))
    plan.parts.append(_bytes_part("README.md", lambda: _readme(plan, specs).encode()))
    # Last: it reports the row counts the table parts have just counted.
    metadata = _bytes_part(
        "metadata.json", lambda: (json.dumps(plan.metadata(), indent=2) + "\n").encode()
    )
    plan.parts.append(metadata)
    return plan


def _add_table_parts(db: DbSession, plan: ExportPlan, table: TableSpec) -> None:
    source = table_source(db, plan, table.name)
    counter = plan.row_counts.setdefault(table.name, [0])
    columns = table.column_names
    text = _guarded(plan.request, [c.name for c in table.columns if c.type == "string"])
    plan.parts.append(
        Part(f"{table.name}.csv", lambda s: writers.write_csv(s, columns, source(), counter, text))
    )
    if "parquet" in plan.request.formats:
        plan.parts.append(
            Part(
                f"{table.name}.parquet",
                lambda s: writers.write_parquet(s, table, source(), [0]),
                needs_seek=True,
            )
        )
    if "json" in plan.request.formats:
        plan.parts.append(
            Part(f"{table.name}.json", lambda s: writers.write_json(s, columns, source(), [0]))
        )
    for fmt in ("sav", "dta"):
        if fmt in plan.request.formats:
            plan.parts.append(_statfile_part(plan, table, source, fmt))


def _guarded(request: ExportRequest, text_columns: Iterable[str]) -> list[str]:
    return [] if request.raw_csv else list(text_columns)


def _statfile_part(
    plan: ExportPlan, table: TableSpec, source: Callable[[], Iterable[Row]], fmt: StatFormat
) -> Part:
    """SPSS/Stata need the whole table at once (pyreadstat writes a file)."""

    def write(stream: IO[bytes]) -> Iterator[None]:
        write_statfile(stream, table, table_frame(table, source()), plan.spec, fmt)
        yield

    return Part(f"{table.name}.{fmt}", write, needs_seek=True)


def _xlsx_part(db: DbSession, plan: ExportPlan, specs: list[TableSpec]) -> Part:
    def write(stream: IO[bytes]) -> Iterator[None]:
        sheets = [(t.name, t.column_names, table_source(db, plan, t.name)()) for t in specs]
        sheets.append(("codebook", list(CODEBOOK_COLUMNS), codebook_rows(specs)))
        times = {t.name: [c.name for c in t.columns if c.type == "datetime"] for t in specs}
        yield from writers.write_xlsx(stream, sheets, times)

    return Part("data.xlsx", write, needs_seek=True)


def _readme(plan: ExportPlan, specs: list[TableSpec]) -> str:
    lines = [
        f"# Export of study '{plan.study.name}' (config {plan.study.config_hash[:12]})",
        "",
        "Tidy tables, one row per observation; codebook.csv describes every column, and",
        "datapackage.json (a Frictionless Data Package) gives each table's types, allowed",
        "values and keys for tools: frictionless validate datapackage.json.",
        f"Rehearsal sessions are {'included' if plan.request.include_rehearsal else 'excluded'}.",
        "Times are ISO 8601 in UTC (data.xlsx: Excel date-times, in UTC).",
        "Missing values are empty cells. Lists (rankings) are item",
        f"ids joined by '{LIST_SEPARATOR}', rank 1 first. Columns marked possibly_identifying",
        "in the codebook (free-text answers) must be reviewed before sharing the data.",
        *_formula_note(plan),
        "",
        "R:      Rscript analysis.R   (the whole analysis: tests, effect sizes, alpha, models,",
        "                              plots; add '. as_run' for the per-protocol view)",
        "        scores <- read.csv('scores.csv')",
        "pandas: scores = pandas.read_csv('scores.csv')",
        "",
        "Provenance (metadata.json, described in codebook.csv under table metadata.json):",
        "the study configuration's hash and how to recompute it from study_config.json,",
        "the plan seed and planner version, the software version and git commit, and the",
        "prompt catalogue versions. interactions.csv says per interaction which recording",
        "the natural condition replayed (natural_source, natural_recording).",
        "",
        *(f"- {t.name}: {t.description}" for t in specs),
        "",
    ]
    return "\n".join(lines)


CSV_GUARD_NOTE = "(CSV: text starting with = + - @ tab or CR has a leading ', see README.md.)"


def _formula_note(plan: ExportPlan) -> list[str]:
    if plan.request.raw_csv:
        return ["Text cells are as stored (raw CSV): do not open these files in a spreadsheet."]
    return [
        "Text cells starting with = + - @ tab or CR carry a leading ' in the CSV files (OWASP",
        "CSV-injection guidance: a spreadsheet would run them as formulas); data.xlsx stores",
        'all text as text. Strip it in R with sub("^\'([-=+@\\t\\r])", "\\\\1", x), or export',
        "with --raw-csv (metadata.json: csv_formula_guard).",
    ]


def export_to_directory(db: DbSession, request: ExportRequest, out: Path) -> ExportPlan:
    """Write every part as a file under ``out`` (created if needed)."""
    out.mkdir(parents=True, exist_ok=True)
    plan = plan_export(db, request)
    for part in plan.parts:
        with (out / part.name).open("wb") as stream:
            for _ in part.write(stream):
                pass
    return plan


class _Drain:
    """A write-only sink zipfile writes into; the streamer empties it between batches."""

    def __init__(self) -> None:
        self.chunks: list[bytes] = []

    def write(self, data: bytes) -> int:
        self.chunks.append(bytes(data))
        return len(data)

    def flush(self) -> None:
        return None

    def close(self) -> None:
        return None

    def take(self) -> bytes:
        data = b"".join(self.chunks)
        self.chunks.clear()
        return data


def bundle_name(plan: ExportPlan) -> str:
    stamp = datetime.now(UTC).strftime("%Y%m%d-%H%M%S")
    return f"chameleons-study{plan.study.id}-{stamp}.zip"


def stream_zip(
    factory: sessionmaker[DbSession], request: ExportRequest
) -> tuple[str, Iterator[bytes]]:
    """The bundle's file name, and a generator of its bytes.

    The generator has its own database session: a streamed response outlives the request's.
    The study is resolved up front so a bad study id fails before any byte is sent.
    """
    with factory() as db:
        name = bundle_name(plan_export(db, request))

    def chunks() -> Iterator[bytes]:
        with factory() as db:
            plan = plan_export(db, request)
            drain = _Drain()
            with zipfile.ZipFile(drain, "w", compression=zipfile.ZIP_DEFLATED) as archive:
                for part in plan.parts:
                    yield from _zip_part(archive, part, drain)
            yield drain.take()

    return name, chunks()


def _zip_part(archive: zipfile.ZipFile, part: Part, drain: _Drain) -> Iterator[bytes]:
    with archive.open(part.name, "w", force_zip64=True) as entry:
        if part.needs_seek:
            # Parquet and Excel writers seek; they go through a temporary file first.
            with tempfile.TemporaryFile() as spool:
                for _ in part.write(spool):
                    pass
                spool.seek(0)
                while block := spool.read(1 << 20):
                    entry.write(block)
                    if data := drain.take():
                        yield data
        else:
            for _ in part.write(entry):
                if data := drain.take():
                    yield data
    if data := drain.take():
        yield data


__all__ = [
    "FORMATS",
    "ExportFormat",
    "ExportPlan",
    "ExportRequest",
    "export_to_directory",
    "plan_export",
    "stream_zip",
]
