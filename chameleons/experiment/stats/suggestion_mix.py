"""The suggestion mix per condition: how many of the robot's suggestions were optimal and
how many the random fallback (and how many moved an item down), over the analysis's
participants and conditions as its view counts them.

Why it is reported: the kind of a suggestion depends on the participant's earlier decisions
(who accepts reaches the expert order sooner and then gets random suggestions), so the mix
can differ between conditions because acceptance does. The acceptance model therefore
leaves the kind out (the condition's total effect), and the mix is shown beside it so a
reader sees how different the suggestions were. Whether the mix differs is tested on one
number per participant and condition, the number of random suggestions, with the Friedman
test (asymptotic and exact permutation p), so a participant's suggestions are not counted as
independent observations.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

from chameleons.experiment.stats.friedman_test import (
    FriedmanResult,
    PermutationResult,
    friedman,
    permutation_p,
)


@dataclass(frozen=True)
class ConditionMix:
    condition: str
    total: int
    optimal: int
    random: int
    down: int  # suggestions that moved the item down (optimal ones only can)

    @property
    def random_share(self) -> float | None:
        return self.random / self.total if self.total else None

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "random_share": self.random_share}


@dataclass(frozen=True)
class SuggestionMix:
    conditions: list[ConditionMix]
    friedman: FriedmanResult  # on each participant's random count per condition
    permutation: PermutationResult | None
    participants: int  # with suggestions in every condition (the test's n)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "conditions": [c.to_dict() for c in self.conditions],
            "friedman": asdict(self.friedman),
            "permutation": None if self.permutation is None else asdict(self.permutation),
            "participants": self.participants,
            "notes": self.notes,
        }


def suggestion_mix(
    rows: Iterable[Mapping[str, Any]], conditions: Sequence[str], seed: int = 0
) -> SuggestionMix:
    """The mix of ``rows`` (one per suggestion: ``participant``, ``condition`` as the view
    counts it, ``kind``; ``direction`` when known)."""
    counts: Counter[tuple[str, str]] = Counter()
    per_participant: dict[str, Counter[str]] = {}
    seen: dict[str, set[str]] = {}
    for row in rows:
        condition = str(row.get("condition") or "").strip()
        kind = str(row.get("kind") or "").strip()
        participant = str(row.get("participant") or "").strip()
        if kind not in ("optimal", "random") or not condition:
            continue
        counts[(condition, kind)] += 1
        counts[(condition, "down")] += str(row.get("direction") or "").strip() == "down"
        seen.setdefault(participant, set()).add(condition)
        per_participant.setdefault(participant, Counter())[condition] += kind == "random"
    found = [c for c in conditions if counts[(c, "optimal")] + counts[(c, "random")]]
    found += sorted({c for c, _ in counts} - set(conditions))
    mixes = [
        ConditionMix(
            c,
            counts[(c, "optimal")] + counts[(c, "random")],
            counts[(c, "optimal")],
            counts[(c, "random")],
            counts[(c, "down")],
        )
        for c in found
    ]
    complete = [p for p, met in seen.items() if set(conditions) <= met]
    blocks = [[float(per_participant[p][c]) for c in conditions] for p in sorted(complete)]
    notes = []
    if len(complete) < len(seen):
        notes.append(
            f"{len(seen) - len(complete)} participant(s) without suggestions in every "
            "condition left out of the test"
        )
    test = friedman(blocks)
    permutation = permutation_p(blocks, seed=seed) if blocks and len(conditions) > 1 else None
    return SuggestionMix(mixes, test, permutation, len(complete), notes)
