"""How the robot's suggestions came out per condition: optimal or random, up or down.

A random suggestion (the fallback when no move improves the ranking) may make the ranking
worse, and participants found such suggestions odd; a condition that got more of them than
another is a confound for the accepted-suggestions measure. The dashboard shows the mix per
condition and, once every condition has suggestions of both kinds between them, a
chi-squared test of independence of condition and kind (SciPy's ``chi2_contingency``).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Any

from scipy.stats import chi2_contingency
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.queries import joined
from chameleons.backend.models import Interaction, Session, Study, Suggestion
from chameleons.experiment.model import Study as StudySpec

CONFOUND_ALPHA = 0.05


@dataclass(frozen=True)
class ConditionMix:
    condition: str
    label: str
    total: int
    optimal: int
    random: int
    down: int

    @property
    def random_share(self) -> float | None:
        return self.random / self.total if self.total else None

    def to_dict(self) -> dict[str, Any]:
        return {**self.__dict__, "random_share": self.random_share}


@dataclass(frozen=True)
class SuggestionMix:
    conditions: list[ConditionMix]
    chi2: float | None
    p: float | None

    @property
    def confounded(self) -> bool:
        return self.p is not None and self.p < CONFOUND_ALPHA

    def to_dict(self) -> dict[str, Any]:
        return {
            "conditions": [c.to_dict() for c in self.conditions],
            "chi2": self.chi2,
            "p": self.p,
            "confounded": self.confounded,
        }


def suggestion_mix(
    db: DbSession, study: Study, spec: StudySpec, include_rehearsal: bool = False
) -> SuggestionMix:
    """Per condition (as run) the suggestions made so far, by kind and direction."""
    query = (
        select(Interaction.condition, Suggestion.kind, Suggestion.from_rank, Suggestion.to_rank)
        .join(Interaction, Interaction.id == Suggestion.interaction_id)
        .join(Session, Session.id == Interaction.session_id)
    )
    counts: Counter[tuple[str, str]] = Counter()
    for condition, kind, from_rank, to_rank in db.execute(
        joined(query, study.id, include_rehearsal)
    ).tuples():
        counts[(condition, kind)] += 1
        if to_rank > from_rank:
            counts[(condition, "down")] += 1
    labels = {c.id: c.label for c in spec.conditions}
    found = sorted({c for c, _ in counts} - set(labels))  # a condition the study lost
    rows = [
        ConditionMix(
            condition,
            labels.get(condition, condition),
            counts[(condition, "optimal")] + counts[(condition, "random")],
            counts[(condition, "optimal")],
            counts[(condition, "random")],
            counts[(condition, "down")],
        )
        for condition in [*spec.condition_ids, *found]
    ]
    chi2, p = _independence(rows)
    return SuggestionMix(rows, chi2, p)


def _independence(rows: list[ConditionMix]) -> tuple[float | None, float | None]:
    """Chi-squared test of condition x kind; None until it is defined (every condition has
    suggestions, and both kinds occur)."""
    used = [r for r in rows if r.total]
    if len(used) < 2 or len(used) < len(rows):
        return None, None
    if not any(r.random for r in used) or not any(r.optimal for r in used):
        return None, None
    result = chi2_contingency([[r.optimal, r.random] for r in used], correction=False)
    return float(result.statistic), float(result.pvalue)
