"""Finding a block of plan rows whose balance counts are even at every prefix.

A *tally* counts how often each of its cells (e.g. a condition-actor pair) is used; each
row adds a known rate to the ideal of every cell. A block of ``rows`` rows is searched
depth-first so that after every row each count is as close to its ideal as integer
counts allow: ``floor(ideal) <= count <= ceil(ideal)`` ("strict"; at the block's end the
ideal is whole, so the block is exact). When that fails within the node budget the search
is repeated "loose" (``|count - ideal| <= 1`` on the way, exact at the end) and, failing
that too, a greedy choice minimising squared deviations is returned (flagged).
"""

from __future__ import annotations

import math
import random
from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction

Cell = Hashable
Increment = tuple[int, Cell]  # (tally index, cell)


@dataclass
class Tally:
    name: str
    rate: Fraction  # ideal increase of every cell per row
    cells: list[Cell]  # a row adds at most 1 to a cell
    checked_on_the_way: bool = True  # False: only exact at the block's end
    counts: dict[Cell, int] = field(default_factory=dict)

    def reset(self) -> None:
        self.counts = dict.fromkeys(self.cells, 0)


@dataclass(frozen=True)
class Option:
    """One choice for a row: what it adds to the tallies, and what the caller wants back."""

    increments: tuple[Increment, ...]
    value: tuple[int, ...]


@dataclass(frozen=True)
class SearchResult:
    values: list[tuple[int, ...]]
    mode: str  # "strict", "loose" or "greedy"


def find_block(
    options_per_row: Sequence[Sequence[Option]],
    tallies: list[Tally],
    rng: random.Random,
    *,
    budget: int = 20_000,
    restarts: int = 8,
) -> SearchResult:
    for mode in ("strict", "loose"):
        for _ in range(restarts):
            found = _Search(options_per_row, tallies, rng, mode, budget).run()
            if found is not None:
                return SearchResult(found, mode)
    return SearchResult(_greedy(options_per_row, tallies, rng), "greedy")


def _bounds(tally: Tally, rows_done: int, total_rows: int, mode: str) -> tuple[int, int]:
    """Allowed counts after ``rows_done`` rows. Besides the balance bounds, a count must
    still be able to reach its exact final value (a cell gains at most 1 per row)."""
    target = int(tally.rate * total_rows)
    reachable = (target - (total_rows - rows_done), target)
    ideal = tally.rate * rows_done
    if not tally.checked_on_the_way:
        return reachable
    if mode == "strict":
        low, high = math.floor(ideal), math.ceil(ideal)
    else:
        low, high = math.ceil(ideal - 1), math.floor(ideal + 1)
    return max(low, reachable[0]), min(high, reachable[1])


class _Search:
    def __init__(
        self,
        options_per_row: Sequence[Sequence[Option]],
        tallies: list[Tally],
        rng: random.Random,
        mode: str,
        budget: int,
    ) -> None:
        self.options = options_per_row
        self.tallies = tallies
        self.rng = rng
        self.mode = mode
        self.budget = budget
        self.rows = len(options_per_row)
        self.bounds = [
            [_bounds(t, done, self.rows, mode) for done in range(self.rows + 1)] for t in tallies
        ]

    def run(self) -> list[tuple[int, ...]] | None:
        for tally in self.tallies:
            tally.reset()
        chosen: list[tuple[int, ...]] = []
        return chosen if self._extend(chosen) else None

    def _extend(self, chosen: list[tuple[int, ...]]) -> bool:
        row = len(chosen)
        if row == self.rows:
            return True
        candidates = list(self.options[row])
        self.rng.shuffle(candidates)
        soft = [i for i, t in enumerate(self.tallies) if not t.checked_on_the_way]
        if soft:  # tallies only bound at the end: still prefer the evenest prefix
            candidates.sort(
                key=lambda option: _squared_deviation(option, self.tallies, row + 1, soft)
            )
        for option in candidates:
            self.budget -= 1
            if self.budget < 0:
                return False
            self._apply(option, +1)
            if self._fits(row + 1):
                chosen.append(option.value)
                if self._extend(chosen):
                    return True
                chosen.pop()
            self._apply(option, -1)
        return False

    def _apply(self, option: Option, sign: int) -> None:
        for tally_index, cell in option.increments:
            self.tallies[tally_index].counts[cell] += sign

    def _fits(self, rows_done: int) -> bool:
        for tally, bounds in zip(self.tallies, self.bounds, strict=True):
            low, high = bounds[rows_done]
            if any(not low <= count <= high for count in tally.counts.values()):
                return False
        return True


def _greedy(
    options_per_row: Sequence[Sequence[Option]], tallies: list[Tally], rng: random.Random
) -> list[tuple[int, ...]]:
    for tally in tallies:
        tally.reset()
    chosen = []
    for row, options in enumerate(options_per_row, start=1):
        candidates = list(options)
        rng.shuffle(candidates)
        best = min(candidates, key=lambda option: _squared_deviation(option, tallies, row))
        for tally_index, cell in best.increments:
            tallies[tally_index].counts[cell] += 1
        chosen.append(best.value)
    return chosen


def _squared_deviation(
    option: Option, tallies: list[Tally], rows_done: int, which: list[int] | None = None
) -> Fraction:
    added: dict[tuple[int, Cell], int] = {}
    for key in option.increments:
        added[key] = added.get(key, 0) + 1
    total = Fraction(0)
    for index in range(len(tallies)) if which is None else which:
        tally = tallies[index]
        ideal = tally.rate * rows_done
        for cell, count in tally.counts.items():
            total += (count + added.get((index, cell), 0) - ideal) ** 2
    return total
