"""``chameleons import-eaf`` and ``chameleons reliability``: the coders' ELAN annotations
back into the database, and their agreement per tier (issue 33, docs/instruments.md)."""

from __future__ import annotations

import json
from pathlib import Path

import click
from sqlalchemy.exc import SQLAlchemyError

from chameleons.backend.db import build_engine, build_sessionmaker
from chameleons.backend.instruments.eaf import EafError, read_eaf
from chameleons.backend.instruments.reliability import DEFAULT_UNIT_MS, study_reliability
from chameleons.cli.common import load_settings


@click.command("import-eaf")
@click.argument("files", nargs=-1, required=True,
                type=click.Path(dir_okay=False, path_type=Path))  # fmt: skip
@click.option("--session", "session_id", type=int,
              help="The session coded (default: the one the exported file names).")  # fmt: skip
@click.option(
    "--coder", default=None, help="Who coded (default: the tiers' annotator in the file)."
)
@click.option(
    "--all-tiers",
    is_flag=True,
    help="Also keep the tiers this system wrote (prompts, robot speech, ...).",
)
def import_eaf(files: tuple[Path, ...], session_id: int | None, coder: str | None,
               all_tiers: bool) -> None:  # fmt: skip
    """Read coders' ELAN annotations of exported sessions back, for inter-rater
    reliability (a coder's earlier import of the same session is replaced)."""
    settings = load_settings()
    engine = build_engine(settings.effective_database_url)
    try:
        with build_sessionmaker(engine)() as db:
            for path in files:
                done = read_eaf(db, path, session_id=session_id, coder=coder,
                                all_tiers=all_tiers)  # fmt: skip
                db.commit()
                tiers = ", ".join(f"{t} {n}" for t, n in done.tiers.items()) or "no tiers"
                click.echo(f"{path.name}: session {done.session_id}, coder {done.coder}: "
                           f"{tiers}")  # fmt: skip
    except EafError as exc:
        raise click.ClickException(str(exc)) from exc
    except SQLAlchemyError as exc:
        raise click.ClickException(f"could not use the database: {exc}") from exc
    finally:
        engine.dispose()


def _number(value: float | None) -> str:
    return "—" if value is None else f"{value:.3f}"


@click.command("reliability")
@click.option("--study", "study_id", type=int, help="Only this study's sessions (default: all).")
@click.option("--unit-ms", type=click.IntRange(1, 60_000), default=DEFAULT_UNIT_MS,
              show_default=True, help="Length of the time units compared.")  # fmt: skip
@click.option("--format", "fmt", type=click.Choice(("text", "json")), default="text",
              show_default=True)  # fmt: skip
def reliability(study_id: int | None, unit_ms: int, fmt: str) -> None:
    """Inter-rater reliability of the coders' ELAN annotations per tier: Cohen's kappa per
    pair of coders, Fleiss' kappa and Krippendorff's alpha."""
    settings = load_settings()
    engine = build_engine(settings.effective_database_url)
    try:
        with build_sessionmaker(engine)() as db:
            tiers = study_reliability(db, study_id, unit_ms)
    except SQLAlchemyError as exc:
        raise click.ClickException(f"could not use the database: {exc}") from exc
    finally:
        engine.dispose()
    if fmt == "json":
        click.echo(json.dumps({"unit_ms": unit_ms, "tiers": [t.to_dict() for t in tiers]},
                              indent=2))  # fmt: skip
        return
    if not tiers:
        click.echo("No tier was coded by two or more coders on the same session yet "
                   "(chameleons import-eaf).")  # fmt: skip
        return
    for tier in tiers:
        pairs = ", ".join(f"{pair.replace('|', ' vs ')} {_number(kappa)}"
                          for pair, kappa in tier.cohen.items())  # fmt: skip
        click.echo(f"{tier.tier}: {len(tier.coders)} coders, {tier.sessions} session(s), "
                   f"{tier.units} units of {unit_ms} ms; Cohen's kappa {pairs}; "
                   f"Fleiss' kappa {_number(tier.fleiss)}; "
                   f"Krippendorff's alpha {_number(tier.alpha)}")  # fmt: skip
