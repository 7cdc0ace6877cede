"""The robot's suggestion policy, as the session flow uses it: the experiment core's
``next_suggestion``/``apply_suggestion`` (see ``chameleons.experiment.suggestions`` for
the exact rule), seeded per interaction and suggestion so a replay gives the same move.
Rankings are lists of item ids, most important first; ranks are 1-based.
"""

from __future__ import annotations

import random

from chameleons.experiment.suggestions import (
    Rule,
    Suggestion,
    apply_suggestion,
    next_suggestion,
)

__all__ = ["Suggestion", "accept", "move", "propose"]


def propose(
    ranking: list[str], expert_order: list[str], declined: set[str], seed: str, rule: Rule
) -> Suggestion:
    """The next suggestion under the study's rule, seeded deterministically (the same
    inputs give the same move)."""
    return next_suggestion(ranking, expert_order, frozenset(declined), random.Random(seed), rule)


def accept(ranking: list[str], item: str, from_rank: int, to_rank: int) -> list[str]:
    """The ranking after an accepted suggestion."""
    return apply_suggestion(ranking, Suggestion(item, from_rank, to_rank, "optimal"))


def move(ranking: list[str], item: str, to_rank: int) -> list[str]:
    """The ranking with ``item`` moved to ``to_rank`` (the others keep their order); an
    undo uses it to put an accepted item back where it was."""
    rest = [other for other in ranking if other != item]
    rest.insert(to_rank - 1, item)
    return rest
