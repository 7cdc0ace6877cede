"""Williams designs: condition orders balanced for first-order carry-over effects.

For ``k`` conditions the design is a Latin square whose rows are cyclic shifts of the
sequence ``0, 1, k-1, 2, k-2, ...``; in it every ordered pair of distinct conditions is
adjacent exactly once when ``k`` is even. For odd ``k`` one square cannot do that, so the
design adds the mirror image (each row reversed): ``2k`` sequences in which every ordered
pair is adjacent exactly twice (Williams 1949). For ``k = 3`` that is all six orders.
"""

from __future__ import annotations


def williams_sequences(k: int) -> list[tuple[int, ...]]:
    """The sequences (condition indices 0..k-1) of the Williams design for ``k`` conditions."""
    if k < 1:
        raise ValueError("a Williams design needs at least one condition")
    first = _first_row(k)
    square = [tuple((c + shift) % k for c in first) for shift in range(k)]
    if k % 2 == 0 or k == 1:
        return square
    return square + [tuple(reversed(row)) for row in square]


def _first_row(k: int) -> list[int]:
    """0, 1, k-1, 2, k-2, ... : consecutive differences are all distinct mod k (k even)."""
    row = [0]
    low, high = 1, k - 1
    while len(row) < k:
        row.append(low)
        low += 1
        if len(row) < k:
            row.append(high)
            high -= 1
    return row
