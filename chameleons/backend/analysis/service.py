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
    Analysis,
    AnalysisError,
    Descriptive,
    analyze,
    condition_labels,
    condition_order,
    error_score_table,
    measure_labels,
    measure_ranges,
    render_latex,
    render_text,
)
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
    def condition_labels(self) -> dict[str, str]:
        return condition_labels(self.spec)

    @property
    def condition_order(self) -> list[str]:
        return condition_order(self.spec)

    @property
    def measures(self) -> tuple[str, ...]:
        return self.spec.measures

    def render_options(self) -> dict[str, Any]:
        return {
            "measure_labels": measure_labels(self.spec),
            "measure_ranges": measure_ranges(self.spec),
        }


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
        return render_latex(
            self.analysis, self.scores.condition_labels, **self.scores.render_options()
        )

    @property
    def text(self) -> str:
        if self.analysis is None:
            return self.error or ""
        return render_text(
            self.analysis, self.scores.condition_labels, **self.scores.render_options()
        )


def database_scores(
    db: DbSession, study_id: int | None = None, include_rehearsal: bool = False
) -> StudyScores:
    study = resolve_study(db, study_id)
    spec = study_from_config(study.config)
    return StudyScores(study, spec, score_rows(db, study, spec, include_rehearsal))


def run_analysis(scores: StudyScores, permutations: int | None = None, seed: int = 0) -> Analysis:
    return analyze(
        scores.rows,
        measures=scores.measures,
        condition_order=scores.condition_order,
        permutations=permutations,
        seed=seed,
    )


def error_scores(
    db: DbSession, scores: StudyScores, include_rehearsal: bool = False
) -> dict[str, dict[str, Descriptive]]:
    """Survival-task error scores per condition: before, after and their change."""
    rows: Iterable[dict[str, Any]] = interaction_rows(
        db, scores.study, scores.spec, include_rehearsal
    )
    return error_score_table(rows)


def study_analysis(
    db: DbSession,
    study_id: int | None = None,
    include_rehearsal: bool = False,
    permutations: int | None = None,
) -> StudyAnalysis:
    """Everything the analysis page shows; an unusable data set gives a message, not a 500."""
    scores = database_scores(db, study_id, include_rehearsal)
    errors = error_scores(db, scores, include_rehearsal)
    if not scores.rows:
        return StudyAnalysis(scores, None, "No counted sessions yet: nothing to analyse.", errors)
    try:
        return StudyAnalysis(scores, run_analysis(scores, permutations), None, errors)
    except AnalysisError as exc:
        return StudyAnalysis(scores, None, f"The analysis cannot run: {exc}", errors)


def score_rows_from_database(
    database_url: str, study_id: int | None = None, include_rehearsal: bool = False
) -> tuple[list[dict[str, Any]], StudySpec]:
    """The scores table straight from a database (``chameleons analyze`` without a file),
    with the study it was collected under."""
    from chameleons.backend.db import build_engine, build_sessionmaker

    engine = build_engine(database_url)
    try:
        with build_sessionmaker(engine)() as db:
            scores = database_scores(db, study_id, include_rehearsal)
            return scores.rows, scores.spec
    finally:
        engine.dispose()
