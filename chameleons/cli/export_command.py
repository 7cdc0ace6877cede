"""`chameleons export`: the study's tidy tables, codebook and config into a directory."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import click
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.db import build_engine, build_sessionmaker
from chameleons.backend.export.selection import StudyNotFoundError
from chameleons.backend.export.service import (
    FORMATS,
    ExportFormat,
    ExportRequest,
    export_to_directory,
)
from chameleons.cli.common import load_settings
from chameleons.prompts.locations import prompts_root


@click.command("export")
@click.option(
    "--out",
    "out",
    required=True,
    type=click.Path(file_okay=False, path_type=Path),
    help="Directory to write into (created if missing; files there are overwritten).",
)
@click.option(
    "--format",
    "formats",
    type=click.Choice((*FORMATS, "eaf")),
    multiple=True,
    help="Extra format besides CSV (CSV is always written); repeat for several. eaf: one "
    "ELAN file per session under eaf/ (docs/instruments.md).",
)
@click.option(
    "--instruments",
    is_flag=True,
    help="Also the streams attached with import-xdf, as Parquet under instruments/.",
)
@click.option(
    "--video",
    is_flag=True,
    help="Also the participants' videos (studies that record video), as WebM under video/ "
    "with video/videos.csv; the .eaf files then link these copies. Left out unless asked.",
)
@click.option("--include-rehearsal", is_flag=True, help="Include sessions marked as rehearsals.")
@click.option("--study", "study_id", type=int, help="Study id (default: the newest active).")
@click.option(
    "--raw-csv",
    is_flag=True,
    help="Write CSV text cells as stored, without the leading ' that keeps a spreadsheet "
    "from running = + - @ cells as formulas (for R/pandas only).",
)
def export(
    out: Path,
    formats: tuple[ExportFormat | Literal["eaf"], ...],
    instruments: bool,
    video: bool,
    include_rehearsal: bool,
    study_id: int | None,
    raw_csv: bool,
) -> None:
    """Export participants, interactions, suggestions, questionnaire, scores and events."""
    settings = load_settings()
    engine = build_engine(settings.effective_database_url)
    request = ExportRequest(
        study_id=study_id,
        formats=("csv", *(f for f in formats if f != "eaf")),
        include_rehearsal=include_rehearsal,
        raw_csv=raw_csv,
        prompts_dir=prompts_root(settings),
    )
    try:
        with build_sessionmaker(engine)() as db:
            plan = export_to_directory(db, request, out)
            extra = _instruments(db, plan.study.id, include_rehearsal, settings.data_dir, out,
                                 eaf="eaf" in formats, streams=instruments,
                                 video=video)  # fmt: skip
    except StudyNotFoundError as exc:
        raise click.ClickException(str(exc)) from exc
    except SQLAlchemyError as exc:
        raise click.ClickException(f"could not read the database: {exc}") from exc
    finally:
        engine.dispose()
    counts = ", ".join(f"{name} {count[0]}" for name, count in plan.row_counts.items())
    click.echo(f"exported study {plan.study.id} ({plan.study.name}) to {out}: {counts} rows"
               f"{extra}")  # fmt: skip


def _instruments(db: DbSession, study_id: int, include_rehearsal: bool, data_dir: Path,
                 out: Path, *, eaf: bool, streams: bool, video: bool) -> str:  # fmt: skip
    """The videos, ELAN files and instrument streams asked for; what was written, for the
    report. The ``.eaf`` files link the exported videos, else the server's own files."""
    from chameleons.backend.instruments.export import export_eaf, export_instruments
    from chameleons.backend.video.export import export_videos, stored_videos

    said = ""
    media = None
    if video:
        media = export_videos(db, study_id, include_rehearsal, Path(data_dir), out)
        said += f"; {sum(len(v) for v in media.values())} video(s) in video/"
    if eaf:
        if media is None:
            media = stored_videos(db, study_id, include_rehearsal, Path(data_dir))
        written = export_eaf(db, study_id, include_rehearsal, out, media)
        said += f"; {written} ELAN file(s) in eaf/"
    if streams:
        count = export_instruments(db, study_id, include_rehearsal, Path(data_dir), out)
        said += f"; {count} instrument stream(s) in instruments/"
    return said
