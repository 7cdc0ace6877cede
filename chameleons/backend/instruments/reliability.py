"""Inter-rater reliability of the coders' ELAN annotations, per tier (docs/instruments.md).

Time-sliced agreement: each session a tier was coded in by two or more coders is cut into
units of ``unit_ms`` from the first to the last annotation any of them made there; a unit's
category is the value of the annotation covering its middle, or ``(none)`` where a coder
marked nothing. Over all such units of the tier: Cohen's kappa for each pair of coders and
Fleiss' kappa for all (statsmodels), and Krippendorff's alpha (nominal; the ``krippendorff``
package), which also takes units a coder did not code at all (a session they never coded).
"""

from __future__ import annotations

import itertools
import math
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import CodedAnnotation, Session

NONE = "(none)"
DEFAULT_UNIT_MS = 100


@dataclass
class TierReliability:
    tier: str
    coders: list[str]
    sessions: int
    units: int
    cohen: dict[str, float | None] = field(default_factory=dict)  # "A|B" -> kappa
    fleiss: float | None = None
    alpha: float | None = None
    categories: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"tier": self.tier, "coders": self.coders, "sessions": self.sessions,
                "units": self.units, "cohen_kappa": self.cohen, "fleiss_kappa": self.fleiss,
                "krippendorff_alpha": self.alpha, "categories": self.categories}  # fmt: skip


def _finite(value: float) -> float | None:
    return round(float(value), 4) if math.isfinite(float(value)) else None


def _labels(spans: list[tuple[int, int, str]], middles: np.ndarray) -> np.ndarray:
    """Each unit's category: the value of the (earliest) annotation covering its middle."""
    labels = np.full(len(middles), NONE, dtype=object)
    for begin, end, value in sorted(spans, reverse=True):  # the earliest written last: wins
        low, high = np.searchsorted(middles, [begin, end], side="left")
        labels[low:high] = value or NONE
    return labels


def units_of(annotations: list[CodedAnnotation], coders: list[str],
             unit_ms: int) -> list[list[str | None]]:  # fmt: skip
    """Per unit, each coder's category (None: the coder did not code this session)."""
    by_coder: dict[str, list[tuple[int, int, str]]] = defaultdict(list)
    for a in annotations:
        by_coder[a.coder].append((a.start_ms, a.end_ms, a.value))
    first = min(a.start_ms for a in annotations)
    last = max(a.end_ms for a in annotations)
    middles = np.arange(first, last, unit_ms, dtype=np.float64) + unit_ms / 2
    columns = [_labels(by_coder[c], middles) if c in by_coder else [None] * len(middles)
               for c in coders]  # fmt: skip
    return [list(row) for row in zip(*columns, strict=True)]


def tier_reliability(tier: str, annotations: list[CodedAnnotation],
                     unit_ms: int = DEFAULT_UNIT_MS) -> TierReliability | None:  # fmt: skip
    """The tier's agreement, or None when fewer than two coders coded one session."""
    import krippendorff
    from statsmodels.stats.inter_rater import aggregate_raters, cohens_kappa, fleiss_kappa

    coders = sorted({a.coder for a in annotations})
    by_session: dict[int, list[CodedAnnotation]] = defaultdict(list)
    for a in annotations:
        by_session[a.session_id].append(a)
    rows: list[list[str | None]] = []
    shared = 0
    for session_annotations in by_session.values():
        if len({a.coder for a in session_annotations}) < 2:
            continue
        shared += 1
        rows += units_of(session_annotations, coders, unit_ms)
    if shared == 0 or not rows:
        return None
    categories = sorted({v for row in rows for v in row if v is not None})
    code = {c: i for i, c in enumerate(categories)}
    # Category codes per unit and coder; -1: the coder did not code that session.
    coded = np.array([[-1 if v is None else code[v] for v in row] for row in rows])
    result = TierReliability(tier, coders, shared, len(rows), categories=categories)
    for first, second in itertools.combinations(range(len(coders)), 2):
        both = coded[(coded[:, first] >= 0) & (coded[:, second] >= 0)]
        key = f"{coders[first]}|{coders[second]}"
        if not len(both):
            result.cohen[key] = None
            continue
        table = np.zeros((len(categories), len(categories)))
        np.add.at(table, (both[:, first], both[:, second]), 1)
        result.cohen[key] = _finite(cohens_kappa(table).kappa)
    complete = coded[(coded >= 0).all(axis=1)]
    if len(complete):
        counts, _ = aggregate_raters(complete, n_cat=len(categories))
        result.fleiss = _finite(fleiss_kappa(counts))
    matrix = np.where(coded >= 0, coded, np.nan).T.astype(np.float64)
    if len(categories) > 1:
        result.alpha = _finite(krippendorff.alpha(reliability_data=matrix,
                                                  level_of_measurement="nominal"))  # fmt: skip
    else:
        result.alpha = 1.0  # every unit, every coder: one category
    return result


def study_reliability(db: DbSession, study_id: int | None = None,
                      unit_ms: int = DEFAULT_UNIT_MS) -> list[TierReliability]:  # fmt: skip
    """Per tier coded by two or more coders on a shared session (of the study, or all)."""
    if unit_ms < 1:
        raise ValueError("the unit must be at least 1 ms")
    query = select(CodedAnnotation).join(Session, Session.id == CodedAnnotation.session_id)
    if study_id is not None:
        query = query.where(Session.study_id == study_id)
    by_tier: dict[str, list[CodedAnnotation]] = defaultdict(list)
    for annotation in db.scalars(query.order_by(CodedAnnotation.id)):
        by_tier[annotation.tier].append(annotation)
    results = [tier_reliability(tier, rows, unit_ms) for tier, rows in sorted(by_tier.items())]
    return [r for r in results if r is not None]
