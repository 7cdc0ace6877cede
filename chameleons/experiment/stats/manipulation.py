"""The manipulation check, summarised: how the participants answered the closed questions
of the final questionnaire.

A ``robot`` item ("Which robot imitated your movements?") is answered with one of the
robots the participant met; the export resolves it to that robot's condition
(``named_condition``), so the summary counts conditions: if the copy condition works as
intended and is noticed, ``copy`` collects the answers (the paper cites Bailenson & Yee:
"Most users do not even notice that they are being copied"). A ``choice`` item counts its
options. Skipped answers are counted apart, never as an option.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from chameleons.experiment.model import Questionnaire, QuestionnaireItem

DONT_KNOW = "dont_know"


@dataclass(frozen=True)
class ItemSummary:
    questionnaire: str
    item: str
    text: str
    type: str
    # answer -> participants, in display order (conditions or options, then "don't know")
    counts: dict[str, int] = field(default_factory=dict)
    labels: dict[str, str] = field(default_factory=dict)
    skipped: int = 0

    @property
    def answered(self) -> int:
        return sum(self.counts.values())

    def to_dict(self) -> dict[str, Any]:
        return {**self.__dict__, "answered": self.answered}


def _closed(
    questionnaires: Sequence[Questionnaire],
) -> list[tuple[Questionnaire, QuestionnaireItem]]:
    return [
        (q, item)
        for q in questionnaires
        if q.phase == "final"
        for item in q.items
        if item.type in ("robot", "choice")
    ]


def _answer(row: Mapping[str, Any], item: QuestionnaireItem) -> str | None:
    if str(row.get("skipped", "")).strip().lower() in ("true", "1"):
        return None
    text = str(row.get("text") or "").strip()
    if item.type == "choice":
        return text or None
    if text == DONT_KNOW:
        return DONT_KNOW
    named = str(row.get("named_condition") or "").strip()
    return named or None


def manipulation_check(
    questionnaires: Sequence[Questionnaire],
    conditions: Mapping[str, str],
    answers: Iterable[Mapping[str, Any]],
    participants: Collection[str] | None = None,
) -> list[ItemSummary]:
    """One summary per closed final item; ``conditions``: id -> label in table order;
    ``participants``: only theirs (the analysis view's), everyone's when None."""
    closed = _closed(questionnaires)
    wanted = {(q.id, item.id): item for q, item in closed}
    counts: dict[tuple[str, str], Counter[str]] = {key: Counter() for key in wanted}
    skipped: Counter[tuple[str, str]] = Counter()
    for row in answers:
        key = (str(row.get("questionnaire", "")), str(row.get("item", "")))
        item = wanted.get(key)
        who = str(row.get("participant", "")).strip()
        if item is None or (participants is not None and who not in participants):
            continue
        answer = _answer(row, item)
        if answer is None:
            skipped[key] += 1
        else:
            counts[key][answer] += 1
    summaries = []
    for q, item in closed:
        key = (q.id, item.id)
        if item.type == "choice":
            labels = {option.id: option.label for option in item.options}
        else:
            labels = {**dict(conditions), DONT_KNOW: "Don't know"}
        ordered = {answer: counts[key].get(answer, 0) for answer in labels}
        summaries.append(
            ItemSummary(q.id, item.id, item.text, item.type, ordered, labels, skipped[key])
        )
    return summaries
