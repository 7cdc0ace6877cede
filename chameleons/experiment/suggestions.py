"""The robot's suggestion policy and the survival-task error score.

Ranks are 1-based positions in the participant's ranking of the interaction's items
(five in the default study); the *expert order* is the same items sorted by expert rank,
and an item's *place* is its rank in it. A suggestion moves one item to another rank; the
items in between shift by one.

The paper: the robot "would request to change the order of three items such that it would
better conform to a pre-determined optimal order ... If the order already was at its
optimal configuration or only objects that the participant has declined are in an
suboptimal position, the agent would randomly choose an item to move to a position above
its current position." Three rules are offered (the study's ``suggestion_rule``):

1. **expert_place** (the default; the closest literal reading). *Random exactly when the
   paper says*: when every item the participant has not declined is at its place.
   Otherwise one such misplaced item is moved *to its place* ("conform to the optimal
   order"): of those moves, one that lowers the error ("better conform") when any does
   (one always does unless the declined items block it: then the error stays the same,
   since moving an item to its place never raises it); among them a move *up* first (the
   paper's robot asked to put items higher; its fallback moves up too), then the most
   important item. The random fallback (the paper's "randomly choose an item to move to a
   position above its current position"): an item is drawn uniformly among those not at
   rank 1 (items not declined preferred), then a rank above it uniformly.
2. **best_move** (the default before ``expert_place``; kept so the studies that ran it
   keep their meaning). Of every move of an item the participant has not declined, to any other
   rank, *up or down*, take the one giving the smallest error score. If it is strictly
   smaller than now, it is proposed as ``optimal``. Ties: the most important item (by
   expert rank) first, then the target nearest that item's expert position, then the
   shorter move. Random when no move lowers the error (even while an item not declined is
   misplaced).
3. **up_only** (what this software did before the rule was a setting). Go through the items
   not declined, most important first; for one sitting below its expert position, take
   the move up (to a rank from its expert position to one above its current rank) with
   the smallest error (ties: nearest its expert position); the first such move that
   strictly lowers the error is proposed. With nothing declined: *the most important item
   below its expert position moves up to it*.

The fallback of ``best_move`` and ``up_only`` draws one of all moves *up* (an item not at
rank 1 to any higher rank) uniformly; moves of items not declined are preferred, so a
declined item is proposed again only when no other item can move up. A random move may make
the ranking worse; ``kind`` records it.

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
Rule = Literal["expert_place", "best_move", "up_only"]
RULES: tuple[Rule, ...] = ("expert_place", "best_move", "up_only")
DEFAULT_RULE: Rule = "expert_place"
# When each rule falls back to a random move up (the codebook and preregistration say it).
FALLBACK_WORDS: dict[str, str] = {
    "expert_place": "when every item the participant has not declined is at its place",
    "best_move": "when no move lowers the error",
    "up_only": "when no move up lowers the error",
}


@dataclass(frozen=True)
class Suggestion:
    item: str
    from_rank: int  # 1-based, current rank of ``item``
    to_rank: int  # 1-based, the proposed rank (never ``from_rank``)
    kind: SuggestionKind

    @property
    def direction(self) -> Literal["up", "down"]:
        return "up" if self.to_rank < self.from_rank else "down"


def next_suggestion(
    ranking: Sequence[str],
    expert_order: Sequence[str],
    declined: Collection[str],
    rng: random.Random,
    rule: Rule = DEFAULT_RULE,
) -> Suggestion:
    """The robot's next suggestion (see the module docstring for the exact rule)."""
    _check_same_items(ranking, expert_order)
    if len(ranking) < 2:
        raise ValueError("a suggestion needs at least two ranked items")
    unknown = set(declined) - set(ranking)
    if unknown:
        raise ValueError(f"declined items are not in the ranking: {sorted(unknown)}")
    if rule not in RULES:
        raise ValueError(f"unknown suggestion rule {rule!r} (known: {', '.join(RULES)})")
    if rule == "expert_place":
        return _to_expert_place(ranking, expert_order, declined) or random_item_suggestion(
            ranking, declined, rng
        )
    finder = _best_move if rule == "best_move" else _most_important_up
    return finder(ranking, expert_order, declined) or random_suggestion(ranking, declined, rng)


def apply_suggestion(ranking: Sequence[str], suggestion: Suggestion) -> list[str]:
    """The ranking after an accepted suggestion: the item moves, the ones between shift."""
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


def random_moves(ranking: Sequence[str], declined: Collection[str]) -> list[tuple[str, int, int]]:
    """The moves the random fallback draws from, uniformly: (item, from, to) for every move
    up of an item not declined; only when there is none, every move up of any item."""
    every = [
        (item, from_rank, to_rank)
        for from_rank, item in enumerate(ranking, start=1)
        for to_rank in range(1, from_rank)
    ]
    preferred = [move for move in every if move[0] not in declined]
    return preferred or every


def random_suggestion(
    ranking: Sequence[str], declined: Collection[str], rng: random.Random
) -> Suggestion:
    item, from_rank, to_rank = rng.choice(random_moves(ranking, declined))
    return Suggestion(item, from_rank, to_rank, "random")


def random_items(ranking: Sequence[str], declined: Collection[str]) -> list[str]:
    """The items ``expert_place``'s fallback draws from, uniformly: every item not at rank 1
    and not declined; only when there is none, every item not at rank 1."""
    movable = list(ranking[1:])
    return [item for item in movable if item not in declined] or movable


def random_item_suggestion(
    ranking: Sequence[str], declined: Collection[str], rng: random.Random
) -> Suggestion:
    """The paper's fallback read literally: an item at random, then a rank above it."""
    item = rng.choice(random_items(ranking, declined))
    from_rank = list(ranking).index(item) + 1
    return Suggestion(item, from_rank, rng.randint(1, from_rank - 1), "random")


def misplaced(
    ranking: Sequence[str], expert_order: Sequence[str], declined: Collection[str]
) -> list[str]:
    """Items not declined that are not at their place in the expert order, most important
    first (the paper's fallback is for when there is none)."""
    return [
        item
        for place, item in enumerate(expert_order)
        if item not in declined and ranking.index(item) != place
    ]


def _to_expert_place(
    ranking: Sequence[str], expert_order: Sequence[str], declined: Collection[str]
) -> Suggestion | None:
    current = error_score(ranking, expert_order)
    best: tuple[bool, bool, int] | None = None
    chosen: Suggestion | None = None
    for item in misplaced(ranking, expert_order, declined):
        from_rank, place = ranking.index(item) + 1, expert_order.index(item) + 1
        lowers = _error_after(ranking, expert_order, item, from_rank, place) < current
        key = (not lowers, place > from_rank, place)  # lowers, then up, then importance
        if best is None or key < best:
            best, chosen = key, Suggestion(item, from_rank, place, "optimal")
    return chosen


def _best_move(
    ranking: Sequence[str], expert_order: Sequence[str], declined: Collection[str]
) -> Suggestion | None:
    current = error_score(ranking, expert_order)
    best: tuple[int, int, int, int] | None = None
    chosen: Suggestion | None = None
    for from_rank, item in enumerate(ranking, start=1):
        if item in declined:
            continue
        goal = expert_order.index(item) + 1
        for to_rank in range(1, len(ranking) + 1):
            if to_rank == from_rank:
                continue
            error = _error_after(ranking, expert_order, item, from_rank, to_rank)
            key = (error, goal, abs(to_rank - goal), abs(to_rank - from_rank))
            if best is None or key < best:
                best, chosen = key, Suggestion(item, from_rank, to_rank, "optimal")
    return chosen if best is not None and best[0] < current else None


def _most_important_up(
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


def _check_same_items(ranking: Sequence[str], expert_order: Sequence[str]) -> None:
    if len(set(ranking)) != len(ranking):
        raise ValueError("a ranking cannot hold an item twice")
    if sorted(ranking) != sorted(expert_order):
        raise ValueError("the ranking and the expert order must hold the same items")
