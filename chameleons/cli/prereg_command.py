"""``chameleons prereg``: the preregistration document (Markdown) for a study."""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import click

from chameleons.cli.plan_command import load_study_option


def _read_power(path: Path | None) -> dict[str, Any] | None:
    if path is None:
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise click.ClickException(f"cannot read {path}: {exc}") from exc
    if not isinstance(data, dict) or not {"rows", "settings", "design"} <= set(data):
        raise click.ClickException(f"{path} is not the output of 'chameleons power --format json'")
    return data


@click.command("prereg")
@click.option("--out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="File to write (default: standard output).")  # fmt: skip
@click.option(
    "--power",
    "power_path",
    type=click.Path(dir_okay=False, path_type=Path),
    help="A power simulation to include (chameleons power --format json > FILE).",
)
@click.option("--study", "study_path", type=click.Path(dir_okay=False, path_type=Path),
              help="A study YAML instead of the database's study (then give --participants "
              "and --plan-seed).")  # fmt: skip
@click.option("--study-id", type=int, default=None,
              help="Database mode: study id (default: the newest active).")  # fmt: skip
@click.option("--participants", type=click.IntRange(min=1), default=None,
              help="With --study: the planned N.")  # fmt: skip
@click.option("--plan-seed", type=int, default=0, show_default=True, help="With --study.")
def prereg_command(
    out: Path | None,
    power_path: Path | None,
    study_path: Path | None,
    study_id: int | None,
    participants: int | None,
    plan_seed: int,
) -> None:
    """Hypotheses, design, planned N with its power, variables and the analysis plan, as
    one Markdown document to upload to OSF before data collection."""
    from chameleons.experiment.prereg import PlanFacts, preregistration

    power = _read_power(power_path)
    if study_path is not None:
        if participants is None:
            raise click.ClickException("--study needs --participants (the planned N)")
        spec = load_study_option(study_path)
        facts = PlanFacts(plan_seed, participants, spec.content_hash, _today())
        text = preregistration(spec, facts, power)
    else:
        text = _from_database(study_id, power)
    if out is None:
        click.echo(text, nl=False)
    else:
        out.write_text(text, encoding="utf-8")
        click.echo(f"wrote {out}", err=True)


def _today() -> str:
    return datetime.now(UTC).date().isoformat()


def _from_database(study_id: int | None, power: dict[str, Any] | None) -> str:
    from sqlalchemy.exc import SQLAlchemyError

    from chameleons.backend.db import build_engine, build_sessionmaker
    from chameleons.backend.export.selection import StudyNotFoundError, resolve_study
    from chameleons.backend.planning.service import preregistration_markdown
    from chameleons.cli.common import load_settings

    engine = build_engine(load_settings().effective_database_url)
    try:
        with build_sessionmaker(engine)() as db:
            return preregistration_markdown(db, resolve_study(db, study_id), power)
    except StudyNotFoundError as exc:
        raise click.ClickException(str(exc)) from exc
    except SQLAlchemyError as exc:
        raise click.ClickException(f"could not read the database: {exc}") from exc
    finally:
        engine.dispose()
