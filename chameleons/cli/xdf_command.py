"""``chameleons import-xdf``: attach an XDF recording's streams to a session (issue 33,
docs/instruments.md)."""

from __future__ import annotations

from pathlib import Path

import click
from sqlalchemy.exc import SQLAlchemyError

from chameleons.backend.db import build_engine, build_sessionmaker
from chameleons.backend.instruments.xdf_import import XdfImportError, import_xdf
from chameleons.cli.common import load_settings


@click.command("import-xdf")
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--session", "session_id", type=int, required=True,
              help="The session the recording was made beside.")  # fmt: skip
@click.option(
    "--include-own",
    is_flag=True,
    help="Also keep this system's own streams (its markers and faces).",
)
def import_xdf_command(file: Path, session_id: int, include_own: bool) -> None:
    """Attach the other instruments' streams of an XDF recording (EMG, eye tracking,
    physiology, other tools' markers) to a session, aligned through this system's LSL
    markers."""
    settings = load_settings()
    engine = build_engine(settings.effective_database_url)
    try:
        with build_sessionmaker(engine)() as db:
            result = import_xdf(db, session_id, file, Path(settings.data_dir),
                                include_own=include_own)  # fmt: skip
            db.commit()
            fit = result.fit
            click.echo(f"aligned on {fit.markers} marker(s) of {fit.marker_stream}: "
                       f"offset {fit.offset:.6f} s, rate {fit.slope:.9f}, "
                       f"largest residual {fit.residual_ms:.3f} ms")  # fmt: skip
            for row in result.streams:
                span = ("no samples" if row.first_s is None else
                        f"{row.first_s:.3f} s to {row.last_s:.3f} s")  # fmt: skip
                click.echo(f"  {row.name} ({row.stream_type or 'no type'}, "
                           f"{len(row.channels)} channel(s), {row.samples} samples): {span}"
                           f" -> {row.path}")  # fmt: skip
            if result.skipped:
                click.echo(f"  left out (this system's own): {', '.join(result.skipped)}")
    except XdfImportError as exc:
        raise click.ClickException(str(exc)) from exc
    except SQLAlchemyError as exc:
        raise click.ClickException(f"could not use the database: {exc}") from exc
    finally:
        engine.dispose()
