"""Scoring questionnaires: a topic's score is the mean of its numeric items, reverse-keyed
items reversed on the scale first (``points + 1 - value``: 8 - v on a 1..7 scale)."""

from __future__ import annotations

from collections.abc import Mapping

from chameleons.experiment.model import Questionnaire


def score_questionnaire(
    questionnaire: Questionnaire, answers: Mapping[str, int], *, allow_missing: bool = False
) -> float:
    """The questionnaire's score from ``answers`` (item id -> value 1..points).

    Every numeric item must be answered unless ``allow_missing`` (then the mean of the
    answered ones; at least one is needed). Open (text) items are not scored."""
    numeric = {item.id: item for item in questionnaire.numeric_items}
    if not numeric:
        raise ValueError(f"questionnaire {questionnaire.id!r} has no numeric items to score")
    unknown = sorted(set(answers) - set(numeric))
    if unknown:
        raise ValueError(f"{questionnaire.id}: not numeric items of this questionnaire: {unknown}")
    missing = sorted(set(numeric) - set(answers))
    if missing and (not allow_missing or len(missing) == len(numeric)):
        raise ValueError(f"{questionnaire.id}: unanswered items: {missing}")
    values = []
    for item_id, value in answers.items():
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{questionnaire.id}.{item_id}: {value!r} is not a whole number")
        if not 1 <= value <= questionnaire.points:
            raise ValueError(
                f"{questionnaire.id}.{item_id}: {value} is outside 1..{questionnaire.points}"
            )
        values.append(questionnaire.points + 1 - value if numeric[item_id].reverse else value)
    return sum(values) / len(values)
