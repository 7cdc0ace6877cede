"""Per-interaction measures: accepted suggestions, questionnaire scores, ranking error.

The scores table (one row per participant x interaction: every planned interaction, run or
not) is what the analysis reads, from the database as well as from an exported
``scores.csv``; both go through :func:`score_rows`, so the two paths cannot disagree. A
measure that was not recorded is missing (empty), never 0: ``accepted`` needs every
suggestion of the interaction decided, a questionnaire score every item answered.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.queries import counted_interactions, session_status
from chameleons.backend.models import QuestionnaireResponse, Study
from chameleons.experiment import suggestions
from chameleons.experiment.model import Questionnaire
from chameleons.experiment.model import Study as StudySpec
from chameleons.experiment.questionnaires import score_questionnaire


def error_score(spec: StudySpec, task: str, ranking: Sequence[str] | None) -> int | None:
    """The experiment core's survival-task error score, expert ranks taken among the ranked
    items (0 = expert order); None for a missing or unusable ranking."""
    if not ranking:
        return None
    try:
        expert_ranks = {item.id: item.expert_rank for item in spec.task(task).items}
        return suggestions.error_score(list(ranking), expert_ranks)
    except (KeyError, ValueError):
        return None


def questionnaire_score(questionnaire: Questionnaire, values: dict[str, int]) -> float | None:
    """The experiment core's score (mean of the numeric items, reverse-keyed ones reversed);
    None unless every numeric item has a valid answer."""
    numeric = {item.id for item in questionnaire.numeric_items}
    try:
        answers = {item: value for item, value in values.items() if item in numeric}
        return score_questionnaire(questionnaire, answers)
    except ValueError:
        return None


def _answers_by_interaction(
    db: DbSession, interaction_ids: list[int]
) -> dict[int, dict[str, dict[str, int]]]:
    """interaction id -> questionnaire id -> item id -> raw value."""
    answers: dict[int, dict[str, dict[str, int]]] = defaultdict(lambda: defaultdict(dict))
    if not interaction_ids:
        return answers
    query = select(
        QuestionnaireResponse.interaction_id,
        QuestionnaireResponse.questionnaire,
        QuestionnaireResponse.item,
        QuestionnaireResponse.value,
    ).where(
        QuestionnaireResponse.interaction_id.in_(interaction_ids),
        QuestionnaireResponse.value.is_not(None),
    )
    for interaction_id, questionnaire, item, value in db.execute(query):
        answers[interaction_id][questionnaire][item] = value
    return answers


def score_rows(
    db: DbSession, study: Study, spec: StudySpec, include_rehearsal: bool
) -> list[dict[str, Any]]:
    """One row per counted interaction (= participant x condition when the plan was kept)."""
    records = counted_interactions(db, study.id, include_rehearsal)
    answers = _answers_by_interaction(db, [record.interaction.id for record in records])
    scored = [q for q in spec.questionnaires_for("interaction") if q.scored]
    rows = []
    for record in records:
        interaction = record.interaction
        row: dict[str, Any] = {
            "participant": record.code,
            "condition": interaction.condition,
            "position": interaction.position,
            "accepted": record.accepted(spec.suggestions_per_interaction),
        }
        for questionnaire in scored:
            row[questionnaire.id] = questionnaire_score(
                questionnaire, answers[interaction.id][questionnaire.id]
            )
        row.update(
            {
                "planned_condition": interaction.planned_condition,
                "deviation": interaction.condition != interaction.planned_condition,
                "suggestions_decided": record.decisions.decided,
                "interaction_status": record.status,
                "session_status": session_status(record.session),
            }
        )
        rows.append(row)
    return rows
