"""``chameleons analyze``: the paper's analysis (Table I, Friedman tests) from score rows."""

from __future__ import annotations

import csv
import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Literal

import click

from chameleons.experiment.model import Study
from chameleons.experiment.stats import (
    AnalysisError,
    analyze,
    condition_labels,
    condition_order,
    measure_labels,
    measure_ranges,
    render_latex,
    render_text,
)
from chameleons.experiment.study import StudyError, load_default_study, study_from_config

REQUIRED_COLUMNS = ("participant", "condition")
STUDY_CONFIG_NAME = "study_config.json"  # written next to scores.csv by the export


def analysis_output(
    rows: Iterable[Mapping[str, Any]],
    output_format: str = "text",
    *,
    permutations: int | None = None,
    seed: int = 0,
    alpha: float = 0.05,
    latex_layout: Literal["paper", "wide"] = "paper",
    study: Study | None = None,
) -> str:
    """The analysis of score rows rendered as text, JSON or LaTeX (any row source: a CSV
    file, the database). ``study`` gives the measures, the condition labels and order and
    the value ranges (default: the paper's study). Raises ``click.ClickException`` for
    unusable rows."""
    spec = study or load_default_study()
    try:
        analysis = analyze(
            rows, measures=spec.measures, condition_order=condition_order(spec),
            permutations=permutations, seed=seed, alpha=alpha,
        )  # fmt: skip
    except AnalysisError as exc:
        raise click.ClickException(str(exc)) from exc
    labels = condition_labels(spec)
    options = {"measure_labels": measure_labels(spec), "measure_ranges": measure_ranges(spec)}
    if output_format == "json":
        return json.dumps(analysis.to_dict(), indent=2)
    if output_format == "latex":
        return render_latex(analysis, labels, layout=latex_layout, **options)
    return render_text(analysis, labels, **options)


def study_beside(path: Path) -> Study | None:
    """The study an exported ``scores.csv`` was collected under (``study_config.json`` beside
    it), or None when there is none."""
    config_path = path.with_name(STUDY_CONFIG_NAME)
    if not config_path.is_file():
        return None
    try:
        return study_from_config(json.loads(config_path.read_text(encoding="utf-8")))
    except (OSError, ValueError) as exc:  # StudyError is a ValueError
        problems = exc.problems if isinstance(exc, StudyError) else [str(exc)]
        raise click.ClickException(f"{config_path}: {'; '.join(problems)}") from exc


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
    help="scores.csv: participant, condition, accepted, credibility, likeability, trust; "
    "the export's study_config.json beside it gives the study's measures and labels. "
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
    study: Study | None
    if scores_path is not None:
        rows: list[dict[str, Any]] = list(read_scores_csv(scores_path))
        study = study_beside(scores_path)
    else:
        rows, study = database_score_rows(study_id, include_rehearsal)
    click.echo(
        analysis_output(
            rows,
            output_format,
            permutations=permutations,
            seed=seed,
            alpha=alpha,
            latex_layout=latex_layout,
            study=study,
        )
    )


def database_score_rows(
    study_id: int | None, include_rehearsal: bool
) -> tuple[list[dict[str, Any]], Study]:
    """The export's scores rows read from the configured database, and their study."""
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
