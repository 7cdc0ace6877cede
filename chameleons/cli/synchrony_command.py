"""``chameleons synchrony``: compute (again) the recorded faces' synchrony of a study's,
a session's or one interaction's interactions, and store it (issue 32)."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import click
from sqlalchemy.exc import SQLAlchemyError

from chameleons.backend.db import build_engine, build_sessionmaker
from chameleons.backend.export.selection import StudyNotFoundError, resolve_study
from chameleons.backend.models import InteractionSynchrony
from chameleons.backend.synchrony import repository, service
from chameleons.cli.common import load_settings


@click.command("synchrony")
@click.option("--study", "study_id", type=int, help="Study id (default: the newest active).")
@click.option("--session", "session_id", type=int, help="Only this session's interactions.")
@click.option("--interaction", "interaction_id", type=int, help="Only this interaction.")
@click.option("--window", type=float, default=None, help="Window in seconds (default: settings).")
@click.option("--increment", type=float, default=None, help="Window increment in seconds.")
@click.option("--max-lag", type=float, default=None, help="Largest lag in seconds, both ways.")
@click.option("--surrogates", type=click.IntRange(0, 1000), default=None,
              help="Pseudo-pairs per interaction.")  # fmt: skip
def synchrony(
    study_id: int | None,
    session_id: int | None,
    interaction_id: int | None,
    window: float | None,
    increment: float | None,
    max_lag: float | None,
    surrogates: int | None,
) -> None:
    """Compute the synchrony of the recorded faces per interaction: the robot following the
    participant, the participant following the robot, and their surrogate baseline."""
    settings = load_settings()
    params = service.params_from(settings)
    changes: dict[str, float | int] = {}
    if window is not None:
        changes.update(window_s=window, segment_s=window)
    if increment is not None:
        changes["increment_s"] = increment
    if max_lag is not None:
        changes["max_lag_s"] = max_lag
    if surrogates is not None:
        changes.update(surrogates=surrogates, min_between=min(params.min_between, surrogates))
    try:
        params = replace(params, **changes)  # type: ignore[arg-type]
    except ValueError as exc:
        raise click.ClickException(str(exc)) from exc
    engine = build_engine(settings.effective_database_url)
    done = failed = 0
    try:
        with build_sessionmaker(engine)() as db:
            study = None
            if session_id is None and interaction_id is None:
                study = resolve_study(db, study_id).id
            ids = repository.interactions_of(db, study, session_id, interaction_id)
            if not ids:
                raise click.ClickException("no recorded interactions to compute")
            for number, interaction in enumerate(ids, 1):
                started = time.perf_counter()
                row = service.compute(db, interaction, Path(settings.data_dir), params)
                db.commit()
                if row is None:
                    continue
                seconds = time.perf_counter() - started
                done += 1
                failed += row.check == "failed"
                click.echo(f"[{number}/{len(ids)}] interaction {interaction}: "
                           f"{_line(row)} ({seconds:.1f} s)")  # fmt: skip
    except StudyNotFoundError as exc:
        raise click.ClickException(str(exc)) from exc
    except SQLAlchemyError as exc:
        raise click.ClickException(f"could not use the database: {exc}") from exc
    finally:
        engine.dispose()
    click.echo(f"computed {done} interaction(s); {failed} copy check(s) failed")


def _line(row: InteractionSynchrony) -> str:
    if row.reason is not None:
        return f"no values: {row.detail}"
    parts = ["no sync peak" if row.sync_r is None or row.sync_lag_s is None else
             f"robot follows at {row.sync_lag_s:.2f} s, r = {row.sync_r:.2f}"]  # fmt: skip
    if row.mimicry_r is not None and row.mimicry_lag_s is not None:
        parts.append(f"mimicry r = {row.mimicry_r:.2f} at {row.mimicry_lag_s:.2f} s")
    parts.append(f"surrogates: {row.surrogate_count} {row.surrogate_kind}")
    if row.check:
        parts.append(f"copy check {row.check}: {row.check_reason}")
    return "; ".join(parts)
