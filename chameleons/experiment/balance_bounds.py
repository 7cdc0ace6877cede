"""How even a count table *can* be with N rows: the smallest possible largest deviation from
the ideal, so the balance report can tell "as even as possible" from "could be better".

A table on its own can always be within 1 of its ideal. Two tables of the report cannot
always be, because other constraints come first: carry-over (ordered pairs of adjacent
conditions) once each condition must be within 1 of its ideal count at every position, and
condition x scenario once scenarios are shown equally often, never twice in a session, and
(when the study says so) with alternating tasks. For those the minimum is found exactly by
an integer program over how many rows of each kind there are (HiGHS, through SciPy's
``milp``). The program is a relaxation (it ignores actors, faces and item orders), so its
minimum is a lower bound: a table that reaches it is provably as even as possible.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp

from chameleons.experiment.model import Study

MAX_ROW_KINDS = 5000  # larger programs are not attempted (no bound: no "minimal" claim)
Kind = tuple[tuple[int, ...], tuple[int, ...]]  # (condition order, scenario sequence)


def carry_over_bound(study: Study, n: int) -> float | None:
    k = len(study.condition_ids)
    if n <= 0 or study.interactions_per_session != k or math.factorial(k) > MAX_ROW_KINDS:
        return None
    kinds = tuple((order, ()) for order in itertools.permutations(range(k)))
    return _solve(kinds, n, k, 0, "carry_over")


def condition_scenario_bound(study: Study, n: int) -> float | None:
    k, scenarios = len(study.condition_ids), study.scenarios
    if n <= 0 or study.interactions_per_session != k:
        return None
    tasks = tuple(s.task for s in scenarios)
    sequences = [
        seq
        for seq in itertools.permutations(range(len(scenarios)), k)
        if not study.alternate_tasks
        or all(tasks[a] != tasks[b] for a, b in itertools.pairwise(seq))
    ]
    if not sequences or math.factorial(k) * len(sequences) > MAX_ROW_KINDS:
        return None
    kinds = tuple(itertools.product(itertools.permutations(range(k)), sequences))
    return _solve(kinds, n, k, len(scenarios), "condition_scenario")


@lru_cache(maxsize=256)
def _solve(kinds: tuple[Kind, ...], n: int, k: int, scenarios: int, table: str) -> float | None:
    """min t over row-kind counts m >= 0 (integers) with sum m = n, every count of the
    prerequisite tables within 1 of its ideal, and every cell of ``table`` within t."""
    rows: list[np.ndarray] = []
    low: list[float] = []
    high: list[float] = []

    def add(coefficients: Sequence[float], t: float, lo: float, hi: float) -> None:
        rows.append(np.array([*coefficients, t]))
        low.append(lo)
        high.append(hi)

    add([1] * len(kinds), 0, n, n)
    for cell in _position_cells(kinds, k):  # each condition at each position, within 1
        add(cell, 0, math.floor(n / k), math.ceil(n / k))
    if table == "carry_over":
        ideal, cells = n / k, _carry_cells(kinds, k)
    else:
        shown = n * k / scenarios
        for cell in _scenario_cells(kinds, scenarios):  # each scenario equally often
            add(cell, 0, math.floor(shown), math.ceil(shown))
        ideal, cells = n / scenarios, _condition_scenario_cells(kinds, k, scenarios)
    for cell in cells:  # |count - ideal| <= t
        add(cell, -1, -np.inf, ideal)
        add(cell, 1, ideal, np.inf)
    cost = np.zeros(len(kinds) + 1)
    cost[-1] = 1
    integrality = np.ones(len(kinds) + 1)
    integrality[-1] = 0
    result = milp(
        cost,
        integrality=integrality,
        bounds=Bounds(np.zeros(len(kinds) + 1), np.full(len(kinds) + 1, np.inf)),
        constraints=LinearConstraint(np.array(rows), low, high),
        options={"time_limit": 10},
    )
    if not result.success or result.x is None:
        return None
    return float(result.x[-1])


def _position_cells(kinds: Sequence[Kind], k: int) -> list[list[float]]:
    return [
        [float(order[position] == condition) for order, _ in kinds]
        for condition in range(k)
        for position in range(k)
    ]


def _carry_cells(kinds: Sequence[Kind], k: int) -> list[list[float]]:
    return [
        [float(sum(pair == (a, b) for pair in itertools.pairwise(order))) for order, _ in kinds]
        for a in range(k)
        for b in range(k)
        if a != b
    ]


def _scenario_cells(kinds: Sequence[Kind], scenarios: int) -> list[list[float]]:
    return [[float(seq.count(s)) for _, seq in kinds] for s in range(scenarios)]


def _condition_scenario_cells(kinds: Sequence[Kind], k: int, scenarios: int) -> list[list[float]]:
    return [
        [
            float(sum(c == condition and s == scenario for c, s in zip(order, seq, strict=True)))
            for order, seq in kinds
        ]
        for condition in range(k)
        for scenario in range(scenarios)
    ]
