"""Cronbach's alpha of each scored questionnaire from the answers (the export's long
``questionnaire`` table), over the participants an analysis uses.

A case is one rating of one robot: a participant's answers to the questionnaire after one
interaction, reverse-keyed items reversed (the table's ``scored_value``; recomputed from
``value`` when a file has no such column). Only complete cases count (every numeric item
answered): alpha is undefined on missing values, and psych::alpha and pingouin drop
incomplete cases the same way by default. The cases of one participant are not independent
(one per condition), so the interval is a description, not a test; docs/science.md says so.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Collection, Iterable, Mapping, Sequence
from typing import Any

from chameleons.experiment.model import Questionnaire
from chameleons.experiment.stats.reliability import Reliability, cronbach_alpha


def _number(value: Any) -> float | None:
    if value is None or (isinstance(value, str) and not value.strip()):
        return None
    try:
        return float(value)
    except (TypeError, ValueError):
        return None


def _scored(row: Mapping[str, Any], questionnaire: Questionnaire, reverse: bool) -> float | None:
    if str(row.get("skipped", "")).strip().lower() in ("true", "1"):
        return None
    if "scored_value" in row:
        return _number(row.get("scored_value"))
    raw = _number(row.get("value"))
    return None if raw is None else (questionnaire.points + 1 - raw if reverse else raw)


def scale_reliability(
    questionnaires: Sequence[Questionnaire],
    answers: Iterable[Mapping[str, Any]],
    participants: Collection[str] | None = None,
) -> list[Reliability]:
    """Alpha with Feldt's interval per scored interaction questionnaire, in study order;
    ``participants``: only theirs (the analysis view's), all when None."""
    scales = {q.id: q for q in questionnaires if q.phase == "interaction" and q.scored}
    cases: dict[str, dict[tuple[str, str, str], dict[str, float]]] = defaultdict(dict)
    for row in answers:
        questionnaire = scales.get(str(row.get("questionnaire", "")).strip())
        participant = str(row.get("participant", "")).strip()
        if questionnaire is None or (participants is not None and participant not in participants):
            continue
        item = next((i for i in questionnaire.numeric_items if i.id == row.get("item")), None)
        if item is None:
            continue
        key = (participant, str(row.get("session", "")), str(row.get("position", "")))
        value = _scored(row, questionnaire, item.reverse)
        if value is not None:
            cases[questionnaire.id].setdefault(key, {})[item.id] = value
    results = []
    for scale_id, questionnaire in scales.items():
        items = [i.id for i in questionnaire.numeric_items]
        complete = [
            [answers_[i] for i in items]
            for _key, answers_ in sorted(cases[scale_id].items())
            if all(i in answers_ for i in items)
        ]
        results.append(cronbach_alpha(scale_id, items, complete))
    return results
