"""Warnings about item wording shared between questionnaires.

The default study's scales overlap on purpose where their sources do (docs/science.md,
"Questionnaires"): McCroskey & Teven's credibility and trustworthiness items both include
honest/dishonest, and "friendly" is a credibility (goodwill) anchor as well as a Reysen
likability statement. A lab that copies items between scales by mistake gets the same
wording twice without noticing, so the loader names every pair; it does not refuse them.
Two items share wording when they have the same anchors (either order), the same
statement, or the same item id (what the questionnaire table's ``item`` column shows).
"""

from __future__ import annotations

from collections.abc import Iterable

from chameleons.experiment.model import Questionnaire, QuestionnaireItem


def _keys(item: QuestionnaireItem) -> set[str]:
    keys = {f"id:{item.id}"}
    if item.type == "differential":
        anchors = sorted(a.strip().lower() for a in (item.left, item.right))
        keys.add("anchors:" + "/".join(anchors))
    elif item.text.strip():
        keys.add("text:" + " ".join(item.text.lower().split()))
    return keys


def _wording(item: QuestionnaireItem) -> str:
    return f"{item.left}/{item.right}" if item.type == "differential" else repr(item.text)


def duplicate_wording(questionnaires: Iterable[Questionnaire]) -> list[str]:
    """One warning per pair of items in different questionnaires that share wording or id,
    placed at the later item (``questionnaires.<id>.items[<i>]``)."""
    seen: dict[str, tuple[str, int, QuestionnaireItem]] = {}
    warnings: list[str] = []
    for questionnaire in questionnaires:
        for index, item in enumerate(questionnaire.items):
            reported: set[tuple[str, int]] = set()
            for key in sorted(_keys(item)):
                earlier = seen.get(key)
                if earlier is None:
                    seen[key] = (questionnaire.id, index, item)
                    continue
                other, other_index, other_item = earlier
                if other == questionnaire.id or (other, other_index) in reported:
                    continue
                reported.add((other, other_index))
                warnings.append(
                    f"questionnaires.{questionnaire.id}.items[{index}]: {_wording(item)} "
                    f"repeats questionnaires.{other}.items[{other_index}] "
                    f"({_wording(other_item)}); keep it only if the source scales both have it"
                )
    return warnings
