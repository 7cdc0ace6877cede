"""Cronbach's alpha of each scored questionnaire from the answers (the export's long
``questionnaire`` table), over the participants an analysis uses.

A case is one rating of one robot: a participant's answers to the questionnaire after one
interaction, reverse-keyed items reversed (the table's ``scored_value``; recomputed from
``value`` when a file has no such column). Only complete cases count (every numeric item
answered): alpha is undefined on missing values, and psych::alpha and pingouin drop
incomplete cases the same way by default.

The cases of one participant are not independent (one per condition), so Feldt's interval,
which assumes independent cases, would be too narrow for the pooled alpha. The pooled alpha
therefore gets a percentile bootstrap interval over participants (each resampled with all
their ratings), and alpha is also given per condition, where every participant contributes
one rating, with Feldt's interval.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import replace
from typing import Any

from chameleons.experiment.model import Questionnaire
from chameleons.experiment.stats.reliability import (
    CLUSTER_BOOTSTRAP,
    DEFAULT_RESAMPLES,
    Reliability,
    cluster_bootstrap_interval,
    cronbach_alpha,
)


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
    *,
    conditions: Mapping[tuple[str, str], str] | None = None,
    condition_order: Sequence[str] = (),
    resamples: int = DEFAULT_RESAMPLES,
    seed: int = 0,
) -> list[Reliability]:
    """Alpha per scored interaction questionnaire, in study order: pooled over all ratings
    with a bootstrap interval over participants, and per condition with Feldt's interval.
    ``participants``: only theirs (the analysis view's), all when None; ``conditions``:
    (participant, position) -> the condition the view counts (default: the answer row's
    ``condition``)."""
    scales = {q.id: q for q in questionnaires if q.phase == "interaction" and q.scored}
    cases: dict[str, dict[tuple[str, str, str], dict[str, float]]] = defaultdict(dict)
    condition_of: dict[tuple[str, str, str], str] = {}
    for row in answers:
        questionnaire = scales.get(str(row.get("questionnaire", "")).strip())
        participant = str(row.get("participant", "")).strip()
        if questionnaire is None or (participants is not None and participant not in participants):
            continue
        item = next((i for i in questionnaire.numeric_items if i.id == row.get("item")), None)
        if item is None:
            continue
        position = str(row.get("position", "")).strip()
        key = (participant, str(row.get("session", "")).strip(), position)
        own = str(row.get("condition") or "").strip()
        condition_of[key] = (conditions or {}).get((participant, position), own)
        value = _scored(row, questionnaire, item.reverse)
        if value is not None:
            cases[questionnaire.id].setdefault(key, {})[item.id] = value
    results = []
    for scale_id, questionnaire in scales.items():
        items = [i.id for i in questionnaire.numeric_items]
        complete = [
            (key, [answers_[i] for i in items])
            for key, answers_ in sorted(cases[scale_id].items())
            if all(i in answers_ for i in items)
        ]
        pooled = _pooled(scale_id, items, complete, resamples, seed)
        found = {condition_of[key] for key, _ in complete}
        order = [c for c in condition_order if c in found] + sorted(found - set(condition_order))
        per_condition = []
        for condition in order:
            chosen = [(key, v) for key, v in complete if condition_of[key] == condition]
            result = cronbach_alpha(scale_id, items, [v for _, v in chosen])
            people = len({key[0] for key, _ in chosen})
            per_condition.append(replace(result, condition=condition, participants=people))
        results.append(replace(pooled, by_condition=per_condition))
    return results


def _pooled(
    scale_id: str,
    items: list[str],
    complete: list[tuple[tuple[str, str, str], list[float]]],
    resamples: int,
    seed: int,
) -> Reliability:
    result = cronbach_alpha(scale_id, items, [values for _, values in complete])
    who = [key[0] for key, _ in complete]
    participants = len(set(who))
    if result.alpha is None or participants == len(who):  # one rating each: Feldt holds
        return replace(result, participants=participants)
    low, high, note = cluster_bootstrap_interval(
        [values for _, values in complete], who, resamples=resamples, seed=seed, key=scale_id
    )
    return replace(
        result,
        ci_low=low,
        ci_high=high,
        method=CLUSTER_BOOTSTRAP,
        participants=participants,
        note=note or result.note,
    )
