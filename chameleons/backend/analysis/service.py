"""Scores from the database into the experiment core's analysis.

The rows are exactly the export's ``scores`` table (:func:`score_rows`), so analysing the
database and analysing an exported ``scores.csv`` give the same numbers.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.rows import interaction_rows
from chameleons.backend.export.scoring import score_rows
from chameleons.backend.export.selection import resolve_study
from chameleons.backend.models import Study
from chameleons.experiment.model import Study as StudySpec
from chameleons.experiment.stats import (
    DEFAULT_RULE,
    DEFAULT_VIEW,
    Analysis,
    AnalysisError,
    Descriptive,
    View,
    WilcoxonRule,
    analyze,
    error_score_table,
    render_latex,
    render_text,
)
from chameleons.experiment.stats.measures import StudyMeasures, study_measures
from chameleons.experiment.study import study_from_config

ERROR_LABELS = {
    "initial_error": "before the robot's suggestions",
    "final_error": "after the robot's suggestions",
    "error_change": "change (after - before)",
}


@dataclass
class StudyScores:
    study: Study
    spec: StudySpec
    rows: list[dict[str, Any]]

    @property
    def design(self) -> StudyMeasures:
        return study_measures(self.spec)

    @property
    def condition_labels(self) -> dict[str, str]:
        return self.design.labels

    @property
    def condition_order(self) -> list[str]:
        return self.design.order

    @property
    def measures(self) -> tuple[str, ...]:
        return self.spec.measures


    @property
    def participant_count(self) -> int:
        return len({row["participant"] for row in self.rows})


@dataclass
class StudyAnalysis:
    scores: StudyScores
    analysis: Analysis | None
    error: str | None
    errors: dict[str, dict[str, Descriptive]]

    @property
    def latex(self) -> str:
        if self.analysis is None:
            return ""
        design = self.scores.design
        return render_latex(
            self.analysis, design.labels, measure_labels=design.titles,
            measure_ranges=design.ranges,
        )  # fmt: skip

    @property
    def text(self) -> str:
        if self.analysis is None:
            return self.error or ""
        design = self.scores.design
        return render_text(
            self.analysis, design.labels, measure_labels=design.titles,
            measure_ranges=design.ranges,
        )  # fmt: skip


def database_scores(
    db: DbSession, study_id: int | None = None, include_rehearsal: bool = False
) -> StudyScores:
    study = resolve_study(db, study_id)
    spec = study_from_config(study.config)
    return StudyScores(study, spec, score_rows(db, study, spec, include_rehearsal))


def run_analysis(
    scores: StudyScores,
    permutations: int | None = None,
    seed: int = 0,
    view: View = DEFAULT_VIEW,
    wilcoxon_rule: WilcoxonRule = DEFAULT_RULE,
) -> Analysis:
    design = scores.design
    return analyze(
        scores.rows,
        measures=design.measures,
        condition_order=scores.condition_order,
        conditions=design.conditions,
        scales=design.scales,
        view=view,
        permutations=permutations,
        seed=seed,
        wilcoxon_rule=wilcoxon_rule,
    )


def error_scores(
    db: DbSession,
    scores: StudyScores,
    include_rehearsal: bool = False,
    analysis: Analysis | None = None,
) -> dict[str, dict[str, Descriptive]]:
    """Survival-task error scores per condition: before, after and their change; with an
    ``analysis``, of the same participants and conditions as its view."""
    rows: Iterable[dict[str, Any]] = interaction_rows(
        db, scores.study, scores.spec, include_rehearsal
    )
    if analysis is not None:
        kept = set(analysis.participants)
        column = "planned_condition" if analysis.view == "as_planned" else "condition"
        rows = [{**row, "condition": row[column]} for row in rows if row["participant"] in kept]
    return error_score_table(rows)


def study_analysis(
    db: DbSession,
    study_id: int | None = None,
    include_rehearsal: bool = False,
    permutations: int | None = None,
    view: View = DEFAULT_VIEW,
    wilcoxon_rule: WilcoxonRule = DEFAULT_RULE,
) -> StudyAnalysis:
    """Everything the analysis page shows; an unusable data set gives a message, not a 500."""
    scores = database_scores(db, study_id, include_rehearsal)
    if not scores.rows:
        errors = error_scores(db, scores, include_rehearsal)
        return StudyAnalysis(scores, None, "No counted sessions yet: nothing to analyse.", errors)
    try:
        analysis = run_analysis(scores, permutations, view=view, wilcoxon_rule=wilcoxon_rule)
    except AnalysisError as exc:
        errors = error_scores(db, scores, include_rehearsal)
        return StudyAnalysis(scores, None, f"The analysis cannot run: {exc}", errors)
    errors = error_scores(db, scores, include_rehearsal, analysis)
    return StudyAnalysis(scores, analysis, None, errors)


def score_rows_from_database(
    database_url: str, study_id: int | None = None, include_rehearsal: bool = False
) -> tuple[StudySpec, list[dict[str, Any]]]:
    """The study and its scores table straight from a database (``chameleons analyze``
    without a file)."""
    from chameleons.backend.db import build_engine, build_sessionmaker

    engine = build_engine(database_url)
    try:
        with build_sessionmaker(engine)() as db:
            scores = database_scores(db, study_id, include_rehearsal)
            return scores.spec, scores.rows
    finally:
        engine.dispose()
