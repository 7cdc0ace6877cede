"""``chameleons analyze``: the paper's analysis (Table I, Friedman tests) from score rows."""

from __future__ import annotations

import csv
import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Literal

import click

from chameleons.experiment.stats import AnalysisError, analyze, render_latex, render_text
from chameleons.experiment.study import load_default_study

REQUIRED_COLUMNS = ("participant", "condition")


def analysis_output(
    rows: Iterable[Mapping[str, Any]],
    output_format: str = "text",
    *,
    permutations: int | None = None,
    seed: int = 0,
    alpha: float = 0.05,
    latex_layout: Literal["paper", "wide"] = "paper",
) -> str:
    """The analysis of score rows rendered as text, JSON or LaTeX (any row source: a CSV
    file, the database). Raises ``click.ClickException`` for unusable rows."""
    try:
        analysis = analyze(rows, permutations=permutations, seed=seed, alpha=alpha)
    except AnalysisError as exc:
        raise click.ClickException(str(exc)) from exc
    labels = {c.id: c.label for c in load_default_study().conditions}
    if output_format == "json":
        return json.dumps(analysis.to_dict(), indent=2)
    if output_format == "latex":
        return render_latex(analysis, labels, layout=latex_layout)
    return render_text(analysis, labels)


def read_scores_csv(path: Path) -> list[dict[str, str]]:
    """Rows of a ``scores.csv`` (the export's shape), with readable errors."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            reader = csv.DictReader(handle)
            rows = list(reader)
            columns = reader.fieldnames or []
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise click.ClickException(f"cannot read {path}: {exc}") from exc
    missing = [c for c in REQUIRED_COLUMNS if c not in columns]
    if missing:
        raise click.ClickException(f"{path}: missing column(s) {', '.join(missing)}")
    return rows


@click.command("analyze")
@click.option(
    "--scores",
    "scores_path",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="scores.csv: participant, condition, accepted, credibility, likeability, trust. "
    "Without it, the scores come from the database (CHAMELEONS_DATABASE_URL).",
)
@click.option("--study", "study_id", type=int, help="Database mode: study id (default: newest).")
@click.option("--include-rehearsal", is_flag=True, help="Database mode: count rehearsals too.")
@click.option(
    "--format",
    "output_format",
    type=click.Choice(["text", "json", "latex"]),
    default="text",
    show_default=True,
)
@click.option(
    "--permutations",
    type=click.IntRange(min=1),
    default=None,
    help="Add permutation p-values: exact when feasible, else Monte Carlo with N resamples.",
)
@click.option("--seed", type=int, default=0, show_default=True, help="Monte Carlo seed.")
@click.option(
    "--alpha",
    type=click.FloatRange(0, 1, min_open=True, max_open=True),
    default=0.05,
    show_default=True,
)
@click.option(
    "--latex-layout",
    type=click.Choice(["paper", "wide"]),
    default="paper",
    show_default=True,
    help="paper: Table I's layout; wide: a column per condition.",
)
def analyze_command(
    scores_path: Path | None,
    study_id: int | None,
    include_rehearsal: bool,
    output_format: str,
    permutations: int | None,
    seed: int,
    alpha: float,
    latex_layout: Literal["paper", "wide"],
) -> None:
    """Descriptives, Friedman tests (Bonferroni, Kendall's W) and post-hoc tests."""
    if scores_path is not None:
        rows = read_scores_csv(scores_path)
    else:
        rows = database_score_rows(study_id, include_rehearsal)
    click.echo(
        analysis_output(
            rows,
            output_format,
            permutations=permutations,
            seed=seed,
            alpha=alpha,
            latex_layout=latex_layout,
        )
    )


def database_score_rows(study_id: int | None, include_rehearsal: bool) -> list[dict[str, Any]]:
    """The export's scores rows read from the configured database."""
    from sqlalchemy.exc import SQLAlchemyError

    from chameleons.backend.analysis.service import score_rows_from_database
    from chameleons.backend.export.selection import StudyNotFoundError
    from chameleons.cli.common import load_settings

    url = load_settings().effective_database_url
    try:
        return score_rows_from_database(url, study_id, include_rehearsal)
    except StudyNotFoundError as exc:
        raise click.ClickException(str(exc)) from exc
    except SQLAlchemyError as exc:
        raise click.ClickException(f"could not read the database: {exc}") from exc
