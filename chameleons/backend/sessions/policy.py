"""The robot's suggestion policy, as the session flow uses it.

ADAPTER: until ``chameleons.experiment.suggestions`` lands, this module implements the
rule of study.md itself: propose the most important (by expert order) not-yet-declined
item that the participant ranked lower than the expert did, moved up to its expert rank
(``optimal``); when no such item exists, move a random item (not already first) to a
random higher rank (``random``). Rankings are lists of item ids, most important first;
ranks are 1-based.
"""

from __future__ import annotations

import random
from dataclasses import dataclass


@dataclass(frozen=True)
class Proposal:
    item: str
    from_rank: int
    to_rank: int
    kind: str


def propose(ranking: list[str], expert_order: list[str], declined: set[str], seed: str) -> Proposal:
    """The next suggestion, seeded deterministically (the same inputs give the same move)."""
    rng = random.Random(seed)
    for expert_rank, item in enumerate(expert_order, start=1):
        current = ranking.index(item) + 1
        if current > expert_rank and item not in declined:
            return Proposal(item, current, expert_rank, "optimal")
    movable = ranking[1:]
    item = rng.choice(movable)
    current = ranking.index(item) + 1
    return Proposal(item, current, rng.randint(1, current - 1), "random")


def move(ranking: list[str], item: str, to_rank: int) -> list[str]:
    """The ranking with ``item`` moved to ``to_rank`` (the others keep their order)."""
    rest = [other for other in ranking if other != item]
    rest.insert(to_rank - 1, item)
    return rest
