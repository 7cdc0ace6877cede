"""Scores from the database into the experiment core's analysis.

The rows are exactly the export's ``scores`` table (:func:`score_rows`), so analysing the
database and analysing an exported ``scores.csv`` give the same numbers.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Any

from sqlalchemy.orm import Session as DbSession

from chameleons.backend.analysis.cache import analyses
from chameleons.backend.analysis.repository import data_version
from chameleons.backend.export.columns import (
    interactions_table,
    questionnaire_table,
    scores_table,
    suggestions_table,
)
from chameleons.backend.export.frames import records, table_frame
from chameleons.backend.export.rows import interaction_rows, questionnaire_rows, suggestion_rows
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
from chameleons.experiment.stats.effect_sizes import BootstrapOptions
from chameleons.experiment.stats.manipulation import ItemSummary, manipulation_check
from chameleons.experiment.stats.measures import StudyMeasures, study_measures
from chameleons.experiment.stats.model_inputs import suggestions_with_item_set
from chameleons.experiment.stats.robot_behaviour import (
    ConditionBehaviour,
    robot_behaviour,
    worth_reporting,
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
    # The export's questionnaire table: item answers, for Cronbach's alpha per scale.
    answers: list[dict[str, Any]] = field(default_factory=list)

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
    # What the robot did per condition (issue 31): the parameter sets recorded per interaction.
    behaviour: list[ConditionBehaviour] = field(default_factory=list)

    @property
    def reports_behaviour(self) -> bool:
        """Whether a condition's parameters varied within the study or drew a random delay."""
        return worth_reporting(self.behaviour)

    @property
    def manipulation(self) -> list[ItemSummary]:
        """The final questionnaire's closed answers (the manipulation check) of the
        analysis's participants, the named robots counted by condition."""
        scores = self.scores
        labels = {c: scores.condition_labels.get(c, c) for c in scores.condition_order}
        kept = None if self.analysis is None else set(self.analysis.participants)
        return manipulation_check(scores.spec.questionnaires, labels, scores.answers, kept)

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
    """The export's scores table, as a typed frame's records (:mod:`..export.frames`)."""
    study = resolve_study(db, study_id)
    spec = study_from_config(study.config)
    scores = table_frame(scores_table(spec), score_rows(db, study, spec, include_rehearsal))
    answers = table_frame(
        questionnaire_table(spec), questionnaire_rows(db, study, spec, include_rehearsal)
    )
    return StudyScores(study, spec, records(scores), records(answers))


def model_rows(
    db: DbSession, scores: StudyScores, include_rehearsal: bool = False
) -> list[dict[str, Any]]:
    """The acceptance model's rows: the export's suggestions with their item set."""
    study, spec = scores.study, scores.spec
    suggestions = table_frame(
        suggestions_table(spec), suggestion_rows(db, study, include_rehearsal)
    )
    interactions = table_frame(
        interactions_table(spec), interaction_rows(db, study, spec, include_rehearsal)
    )
    return suggestions_with_item_set(records(suggestions), records(interactions))


def run_analysis(
    scores: StudyScores,
    permutations: int | None = None,
    seed: int = 0,
    view: View = DEFAULT_VIEW,
    wilcoxon_rule: WilcoxonRule = DEFAULT_RULE,
    suggestions: list[dict[str, Any]] | None = None,
    bootstrap: BootstrapOptions | None = None,
) -> Analysis:
    """The paper's analysis plus effect sizes (``bootstrap``) and the models (the
    acceptance model when ``suggestions`` are given)."""
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
        bootstrap=bootstrap,
        models=suggestions is not None,
        suggestions=suggestions,
        questionnaires=scores.spec.questionnaires,
        answers=scores.answers,
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
    *,
    extended: bool = True,
) -> StudyAnalysis:
    """Everything the analysis page shows; an unusable data set gives a message, not a 500.

    ``extended``: with the effect sizes and the models; without, only the paper's analysis
    (the page's first render). A visit with the data unchanged since the last is served
    from :mod:`.cache` without reading the rows (:mod:`.repository`)."""
    study = resolve_study(db, study_id)
    options = (include_rehearsal, permutations, view, wilcoxon_rule, extended)
    where = (str(db.get_bind().engine.url), study.id, study.created_at, study.config_hash)
    key = ("page", *where, *options, data_version(db))
    result: StudyAnalysis | None = analyses.get(key)
    if result is None:
        result = _computed(db, study.id, include_rehearsal, permutations, view, wilcoxon_rule,
                           extended)  # fmt: skip
        analyses.put(key, result)
    # This request's study row: the cached one belongs to the session that computed it.
    return replace(result, scores=replace(result.scores, study=study))


def _computed(
    db: DbSession,
    study_id: int,
    include_rehearsal: bool,
    permutations: int | None,
    view: View,
    wilcoxon_rule: WilcoxonRule,
    extended: bool,
) -> StudyAnalysis:
    scores = database_scores(db, study_id, include_rehearsal)
    if not scores.rows:
        errors = error_scores(db, scores, include_rehearsal)
        return StudyAnalysis(scores, None, "No counted sessions yet: nothing to analyse.", errors)
    try:
        if extended:
            analysis = _extended(db, scores, include_rehearsal, permutations, view, wilcoxon_rule)
        else:
            analysis = run_analysis(scores, permutations, view=view, wilcoxon_rule=wilcoxon_rule)
    except AnalysisError as exc:
        errors = error_scores(db, scores, include_rehearsal)
        return StudyAnalysis(scores, None, f"The analysis cannot run: {exc}", errors)
    errors = error_scores(db, scores, include_rehearsal, analysis)
    return StudyAnalysis(scores, analysis, None, errors,
                         robot_behaviour(interaction_rows(db, scores.study, scores.spec,
                                                          include_rehearsal),
                                         analysis.participants))  # fmt: skip


def _extended(
    db: DbSession,
    scores: StudyScores,
    include_rehearsal: bool,
    permutations: int | None,
    view: View,
    wilcoxon_rule: WilcoxonRule,
) -> Analysis:
    suggestions = model_rows(db, scores, include_rehearsal)
    bootstrap = BootstrapOptions()
    return run_analysis(scores, permutations, 0, view, wilcoxon_rule, suggestions, bootstrap)


def score_rows_from_database(
    database_url: str, study_id: int | None = None, include_rehearsal: bool = False
) -> tuple[StudySpec, list[dict[str, Any]], list[dict[str, Any]], list[dict[str, Any]]]:
    """The study, its scores table, the acceptance model's rows and the item answers
    straight from a database (``chameleons analyze`` without a file)."""
    from chameleons.backend.db import build_engine, build_sessionmaker

    engine = build_engine(database_url)
    try:
        with build_sessionmaker(engine)() as db:
            scores = database_scores(db, study_id, include_rehearsal)
            suggestions = model_rows(db, scores, include_rehearsal)
            return scores.spec, scores.rows, suggestions, scores.answers
    finally:
        engine.dispose()
