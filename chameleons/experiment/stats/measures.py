"""What a study says about its analysis: the measures, the conditions and their labels, and
the scale of every measure (values outside it are refused)."""

from __future__ import annotations

from dataclasses import dataclass

from chameleons.experiment.model import Study
from chameleons.experiment.stats.scores import Scale


@dataclass(frozen=True)
class StudyMeasures:
    measures: tuple[str, ...]
    conditions: tuple[str, ...]
    labels: dict[str, str]
    scales: dict[str, Scale]


def study_measures(spec: Study) -> StudyMeasures:
    scales = {
        "accepted": Scale(
            0,
            spec.suggestions_per_interaction,
            integer=True,
            what=f"accepted suggestions (of {spec.suggestions_per_interaction})",
        )
    }
    for questionnaire in spec.questionnaires_for("interaction"):
        if questionnaire.scored:
            scales[questionnaire.id] = Scale(
                1, questionnaire.points, what=f"the {questionnaire.title} score (mean of items)"
            )
    return StudyMeasures(
        spec.measures,
        spec.condition_ids,
        {condition.id: condition.label for condition in spec.conditions},
        scales,
    )
