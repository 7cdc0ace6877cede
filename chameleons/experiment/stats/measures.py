"""What a study says about its analysis: the measures, the conditions and their labels, and
the scale of every measure (values outside it are refused)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from chameleons.experiment.model import Study
from chameleons.experiment.stats.analysis import PAPER_CONDITION_ORDER
from chameleons.experiment.stats.scores import Scale


@dataclass(frozen=True)
class StudyMeasures:
    measures: tuple[str, ...]
    conditions: tuple[str, ...]
    labels: dict[str, str]
    scales: dict[str, Scale]
    titles: dict[str, str] = field(default_factory=dict)  # measure -> questionnaire title

    @property
    def order(self) -> list[str]:
        """The order tables list the conditions in: the paper's Table I order for the
        paper's three conditions, otherwise the study's own order."""
        return condition_order(self.conditions)

    @property
    def ranges(self) -> dict[str, str]:
        """Each measure's value range as the tables print it (``0-3``, ``1-7``)."""
        return {m: f"{scale.low:g}-{scale.high:g}" for m, scale in self.scales.items()}


def condition_order(conditions: Sequence[str]) -> list[str]:
    ids = list(conditions)
    return list(PAPER_CONDITION_ORDER) if sorted(ids) == sorted(PAPER_CONDITION_ORDER) else ids


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
                1,
                questionnaire.points,
                what=f"the {questionnaire.title} score (mean of items)",
                mean_of=len(questionnaire.numeric_items),
            )
    return StudyMeasures(
        spec.measures,
        spec.condition_ids,
        {condition.id: condition.label for condition in spec.conditions},
        scales,
        {q.id: q.title for q in spec.questionnaires_for("interaction") if q.scored},
    )
