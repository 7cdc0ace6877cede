"""The robot's suggestion policy and the survival-task error score.

Ranks are 1-based positions in the participant's ranking of the interaction's items
(five in the default study); the *expert order* is the same items sorted by expert rank.
Every suggestion moves one item *up* (``to_rank < from_rank``).

The rule, given the current ranking, the expert order and the items the participant has
already declined in this interaction:

1. **Optimal.** Go through the items that were not declined, most important (by expert
   rank) first. For an item sitting below its expert position, look at every move up to
   a rank from its expert position to its current rank - 1 and take the one giving the
   smallest error score (ties: the target nearest its expert position). The first item
   for which that move strictly lowers the error score is proposed, as ``optimal``.
   With nothing declined this is simply: *the most important item below its expert
   position moves up to its expert position*, which always lowers the error by at least
   2 (every more important item is then already in place, and the item it displaces from
   its expert position moves towards its own).
2. **Random** (the fallback of study.md), when no such move exists: the ranking is in
   expert order, or only moving declined items up would help. A random item
   not at rank 1 moves to a random rank above its current one; items not declined are
   preferred, so a declined item is proposed again only when every other item is at
   rank 1 or declined. Such a move may well make the ranking worse; ``kind`` records it.

The error score is the standard one: the sum over items of |participant rank - expert
rank|. For a partial ranking (a subset of the items) both ranks are taken among the
ranked items only, so a partial ranking is scored like a full ranking of its items.
"""

from __future__ import annotations

import random
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

SuggestionKind = Literal["optimal", "random"]


@dataclass(frozen=True)
class Suggestion:
    item: str
    from_rank: int  # 1-based, current rank of ``item``
    to_rank: int  # 1-based, always above: to_rank < from_rank
    kind: SuggestionKind


def next_suggestion(
    ranking: Sequence[str],
    expert_order: Sequence[str],
    declined: Collection[str],
    rng: random.Random,
) -> Suggestion:
    """The robot's next suggestion (see the module docstring for the exact rule)."""
    _check_same_items(ranking, expert_order)
    if len(ranking) < 2:
        raise ValueError("a suggestion needs at least two ranked items")
    unknown = set(declined) - set(ranking)
    if unknown:
        raise ValueError(f"declined items are not in the ranking: {sorted(unknown)}")
    return _optimal(ranking, expert_order, declined) or _random(ranking, declined, rng)


def apply_suggestion(ranking: Sequence[str], suggestion: Suggestion) -> list[str]:
    """The ranking after an accepted suggestion: the item moves, the ones between shift down."""
    result = list(ranking)
    if not 1 <= suggestion.to_rank <= len(result) or not 1 <= suggestion.from_rank <= len(result):
        raise ValueError(f"ranks out of range for {len(result)} items: {suggestion}")
    if result[suggestion.from_rank - 1] != suggestion.item:
        raise ValueError(f"{suggestion.item!r} is not at rank {suggestion.from_rank}")
    result.pop(suggestion.from_rank - 1)
    result.insert(suggestion.to_rank - 1, suggestion.item)
    return result


def error_score(ranking: Sequence[str], expert_ranks: Mapping[str, int] | Sequence[str]) -> int:
    """Sum of |rank - expert rank| over the ranked items, both ranks taken among them.

    ``expert_ranks`` maps item -> expert rank (any numbers; only their order counts), or is
    the expert order itself. ``ranking`` may hold any subset of those items."""
    ranks = (
        dict(expert_ranks)
        if isinstance(expert_ranks, Mapping)
        else {item: rank for rank, item in enumerate(expert_ranks, start=1)}
    )
    if len(set(ranking)) != len(ranking):
        raise ValueError("a ranking cannot hold an item twice")
    unknown = set(ranking) - set(ranks)
    if unknown:
        raise ValueError(f"items without an expert rank: {sorted(unknown)}")
    expert_position = {
        item: position
        for position, item in enumerate(sorted(ranking, key=lambda i: ranks[i]), start=1)
    }
    return sum(abs(rank - expert_position[item]) for rank, item in enumerate(ranking, start=1))


def _optimal(
    ranking: Sequence[str], expert_order: Sequence[str], declined: Collection[str]
) -> Suggestion | None:
    current = error_score(ranking, expert_order)
    for expert_rank, item in enumerate(expert_order, start=1):
        from_rank = ranking.index(item) + 1
        if item in declined or from_rank <= expert_rank:
            continue
        scored = [
            (_error_after(ranking, expert_order, item, from_rank, to_rank), to_rank)
            for to_rank in range(expert_rank, from_rank)
        ]
        best_error, best_rank = min(scored)
        if best_error < current:
            return Suggestion(item, from_rank, best_rank, "optimal")
    return None


def _error_after(
    ranking: Sequence[str], expert_order: Sequence[str], item: str, from_rank: int, to_rank: int
) -> int:
    moved = apply_suggestion(ranking, Suggestion(item, from_rank, to_rank, "optimal"))
    return error_score(moved, expert_order)


def _random(ranking: Sequence[str], declined: Collection[str], rng: random.Random) -> Suggestion:
    movable = list(ranking[1:])
    preferred = [item for item in movable if item not in declined]
    item = rng.choice(preferred or movable)
    from_rank = ranking.index(item) + 1
    return Suggestion(item, from_rank, rng.randint(1, from_rank - 1), "random")


def _check_same_items(ranking: Sequence[str], expert_order: Sequence[str]) -> None:
    if len(set(ranking)) != len(ranking):
        raise ValueError("a ranking cannot hold an item twice")
    if sorted(ranking) != sorted(expert_order):
        raise ValueError("the ranking and the expert order must hold the same items")
