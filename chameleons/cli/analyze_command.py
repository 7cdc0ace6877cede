"""``chameleons analyze``: the paper's analysis (Table I, Friedman tests) from score rows,
plus effect sizes with bootstrap intervals and the regression models."""

from __future__ import annotations

import csv
import json
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, Literal

import click

from chameleons.experiment.model import Questionnaire, Study
from chameleons.experiment.stats import (
    DEFAULT_RULE,
    DEFAULT_VIEW,
    VIEWS,
    WILCOXON_RULES,
    AnalysisError,
    View,
    WilcoxonRule,
    analyze,
    render_latex,
    render_text,
)
from chameleons.experiment.stats.analysis import PAPER_REFERENCE
from chameleons.experiment.stats.effect_sizes import DEFAULT_RESAMPLES, BootstrapOptions
from chameleons.experiment.stats.measures import StudyMeasures, study_measures
from chameleons.experiment.stats.model_inputs import suggestions_with_item_set
from chameleons.experiment.stats.robot_behaviour import render_text as render_behaviour_text
from chameleons.experiment.stats.robot_behaviour import robot_behaviour, worth_reporting
from chameleons.experiment.stats.synchrony.outcomes import SynchronyAnalysis, analyze_synchrony
from chameleons.experiment.stats.synchrony.render import render_synchrony_text
from chameleons.experiment.study import StudyError, load_default_study, study_from_config

REQUIRED_COLUMNS = ("participant", "condition")
STUDY_CONFIG_NAME = "study_config.json"
Rows = list[dict[str, Any]]


def analysis_output(
    rows: Iterable[Mapping[str, Any]],
    output_format: str = "text",
    *,
    study: StudyMeasures | None = None,
    view: View = DEFAULT_VIEW,
    wilcoxon_rule: WilcoxonRule = DEFAULT_RULE,
    permutations: int | None = None,
    seed: int = 0,
    alpha: float = 0.05,
    latex_layout: Literal["paper", "wide"] = "paper",
    row_name: str = "row",
    first_row: int = 1,
    bootstrap: int = DEFAULT_RESAMPLES,
    models: bool = True,
    suggestions: Iterable[Mapping[str, Any]] | None = None,
    reference: str | None = None,
    questionnaires: Sequence[Questionnaire] = (),
    answers: Iterable[Mapping[str, Any]] | None = None,
    interactions: Iterable[Mapping[str, Any]] | None = None,
) -> str:
    """The analysis of score rows rendered as text, JSON or LaTeX (any row source: a CSV
    file, the database), checked against the study's conditions and scales (default: the
    built-in study). Raises ``click.ClickException`` for unusable rows."""
    design = study or study_measures(load_default_study())
    try:
        analysis = analyze(
            rows,
            measures=design.measures,
            condition_order=design.order,
            conditions=design.conditions,
            scales=design.scales,
            view=view,
            permutations=permutations,
            seed=seed,
            alpha=alpha,
            wilcoxon_rule=wilcoxon_rule,
            row_name=row_name,
            first_row=first_row,
            bootstrap=BootstrapOptions(bootstrap, seed) if bootstrap else None,
            models=models,
            suggestions=suggestions,
            reference=reference,
            questionnaires=questionnaires,
            answers=answers,
        )
    except AnalysisError as exc:
        raise click.ClickException(f"{exc} Nothing was analysed.") from exc
    interactions = None if interactions is None else list(interactions)
    synchrony = _synchrony(interactions, rows, design, view, reference, models)
    behaviour = [] if interactions is None else robot_behaviour(interactions,
                                                                analysis.participants)  # fmt: skip
    if output_format == "json":
        data = analysis.to_dict()
        if synchrony is not None:
            data["synchrony"] = synchrony.to_dict()
        if behaviour:
            data["robot_behaviour"] = [c.to_dict() for c in behaviour]
        return json.dumps(data, indent=2)
    titles, ranges = design.titles, design.ranges
    if output_format == "latex":
        return render_latex(analysis, design.labels, layout=latex_layout,
                            measure_labels=titles, measure_ranges=ranges)  # fmt: skip
    text = render_text(analysis, design.labels, measure_labels=titles, measure_ranges=ranges)
    if synchrony is not None:
        text += "\n" + render_synchrony_text(synchrony, design.labels)
    if worth_reporting(behaviour):  # a condition's parameters varied, or a jittered delay
        text += "\n" + render_behaviour_text(behaviour, design.labels)
    return text


def _synchrony(
    interactions: Iterable[Mapping[str, Any]] | None, scores: Iterable[Mapping[str, Any]],
    design: StudyMeasures, view: View, reference: str | None, models: bool,
) -> SynchronyAnalysis | None:  # fmt: skip
    """Synchrony by condition and the mimicry models (issue 32), when the interaction rows
    carry the synchrony columns."""
    if interactions is None:
        return None
    return analyze_synchrony(
        interactions, scores, conditions=design.order, measures=design.measures,
        reference=reference or PAPER_REFERENCE, view=view, models=models,
    )  # fmt: skip


def read_csv_rows(path: Path, required: Iterable[str] = REQUIRED_COLUMNS) -> list[dict[str, str]]:
    """Rows of an exported CSV table, with readable errors."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            reader = csv.DictReader(handle)
            rows = list(reader)
            columns = reader.fieldnames or []
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise click.ClickException(f"cannot read {path}: {exc}") from exc
    missing = [c for c in required if c not in columns]
    if missing:
        raise click.ClickException(f"{path}: missing column(s) {', '.join(missing)}")
    return rows


def read_scores_csv(path: Path) -> list[dict[str, str]]:
    """Rows of a ``scores.csv`` (the export's shape), with readable errors."""
    return read_csv_rows(path)


def read_suggestions_beside(scores: Path) -> Rows | None:
    """The acceptance model's rows from ``suggestions.csv`` and ``interactions.csv`` in the
    directory of ``scores.csv`` (an export bundle); ``None`` when they are not there."""
    suggestions, interactions = (
        scores.with_name("suggestions.csv"),
        scores.with_name("interactions.csv"),
    )
    if not (suggestions.is_file() and interactions.is_file()):
        return None
    return suggestions_with_item_set(
        read_csv_rows(suggestions, ("participant", "session", "position", "kind", "accepted")),
        read_csv_rows(interactions, ("participant", "session", "position", "item_set")),
    )


def read_answers_beside(scores: Path) -> Rows | None:
    """The item answers (``questionnaire.csv``) beside ``scores.csv``, for Cronbach's alpha;
    ``None`` when the file is not there."""
    path = scores.with_name("questionnaire.csv")
    if not path.is_file():
        return None
    return read_csv_rows(path, ("participant", "session", "position", "questionnaire", "item"))


def study_for_scores(scores: Path, config: Path | None) -> tuple[Study, str | None]:
    """The study the scores were exported from: ``config`` (a ``study_config.json``), else
    the one beside the scores file, else the built-in study (with a note saying so)."""
    path = config or scores.with_name(STUDY_CONFIG_NAME)
    if config is None and not path.is_file():
        return load_default_study(), (
            f"no {STUDY_CONFIG_NAME} beside {scores}: checking the rows against the built-in "
            "study's conditions and scales (--study-config FILE for another)"
        )
    try:
        return study_from_config(json.loads(path.read_text(encoding="utf-8"))), None
    except (OSError, ValueError, StudyError) as exc:
        raise click.ClickException(f"cannot use {path} as the study configuration: {exc}") from exc


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
@click.option(
    "--study-config",
    "config_path",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help=f"With --scores: the study's {STUDY_CONFIG_NAME} (default: the one beside the "
    "scores file, else the built-in study). Sets the conditions and the measures' scales.",
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
    help="The Friedman tests' permutation p-values are exact when feasible (3 conditions up "
    "to 64 participants, 4 up to 8); otherwise Monte Carlo with N resamples (default 10000).",
)
@click.option(
    "--view",
    type=click.Choice(VIEWS),
    default=DEFAULT_VIEW,
    show_default=True,
    help="as_planned: intention to treat, each interaction counts for its planned condition; "
    "as_run: per protocol, participants with a deviation from the plan are left out.",
)
@click.option(
    "--wilcoxon-rule",
    type=click.Choice(WILCOXON_RULES),
    default=DEFAULT_RULE,
    show_default=True,
    help="Which R version's wilcox.test the post-hoc tests follow; they differ only for tied "
    "differences without zeros (R >= 4.6: exact conditional p).",
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
@click.option(
    "--bootstrap",
    type=click.IntRange(min=0, max=100_000),
    default=DEFAULT_RESAMPLES,
    show_default=True,
    help="Bootstrap resamples for the effect sizes' 95% intervals (seeded by --seed); "
    "0 leaves the effect sizes out.",
)
@click.option(
    "--models/--no-models",
    default=True,
    show_default=True,
    help="Fit the regression models (GEE for acceptance: the condition's total effect, and "
    "as a secondary the same adjusted for the suggestion kind; mixed models for the "
    "scores). With --scores, the acceptance model and the suggestion mix read "
    "suggestions.csv and interactions.csv from the same directory.",
)
@click.option(
    "--reference",
    default=None,
    help="Condition the models compare the others with (default: still, else the first).",
)
def analyze_command(
    scores_path: Path | None,
    config_path: Path | None,
    study_id: int | None,
    include_rehearsal: bool,
    output_format: str,
    permutations: int | None,
    view: View,
    wilcoxon_rule: WilcoxonRule,
    seed: int,
    alpha: float,
    latex_layout: Literal["paper", "wide"],
    bootstrap: int,
    models: bool,
    reference: str | None,
) -> None:
    """Descriptives, Friedman tests (Bonferroni, Kendall's W), post-hoc tests, effect sizes
    with bootstrap intervals and the regression models.

    Excluded participants leave every test; so do, in the as_run view, participants with a
    deviation from the plan; a participant without a value in every condition leaves that
    measure. The output says who and why. Impossible values are refused, naming the line.
    """
    if scores_path is not None:
        rows = read_scores_csv(scores_path)
        spec, note = study_for_scores(scores_path, config_path)
        if note:
            click.echo(f"Note: {note}.", err=True)
        row_name, first_row = "line", 2  # a CSV file's data start on its second line
        suggestions = read_suggestions_beside(scores_path)  # the models and the mix use them
        answers = read_answers_beside(scores_path)
        beside = scores_path.with_name("interactions.csv")
        interactions = read_csv_rows(beside) if beside.is_file() else None
    else:
        spec, rows, suggestions, answers = database_score_rows(study_id, include_rehearsal)
        interactions = database_interaction_rows(study_id, include_rehearsal)
        row_name, first_row = "row", 1
    click.echo(
        analysis_output(
            rows,
            output_format,
            study=study_measures(spec),
            view=view,
            wilcoxon_rule=wilcoxon_rule,
            permutations=permutations,
            seed=seed,
            alpha=alpha,
            latex_layout=latex_layout,
            row_name=row_name,
            first_row=first_row,
            bootstrap=bootstrap,
            models=models,
            suggestions=suggestions,
            reference=reference,
            questionnaires=spec.questionnaires,
            answers=answers,
            interactions=interactions,
        )
    )


def database_interaction_rows(study_id: int | None, include_rehearsal: bool) -> Rows:
    """The export's interaction rows (with the synchrony columns) from the database."""
    from chameleons.backend.db import build_engine, build_sessionmaker
    from chameleons.backend.synchrony.analysis import rows_for_analyze
    from chameleons.cli.common import load_settings

    engine = build_engine(load_settings().effective_database_url)
    try:
        with build_sessionmaker(engine)() as db:
            return rows_for_analyze(db, study_id, include_rehearsal)
    finally:
        engine.dispose()


def database_score_rows(
    study_id: int | None, include_rehearsal: bool
) -> tuple[Study, Rows, Rows, Rows]:
    """The study, the export's scores rows, the acceptance model's rows and the item
    answers, read from the configured database."""
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
