"""An independent verifier of the planner: it only calls ``plan()`` and counts for itself.

The facts (conditions, actors, faces, the items of each scenario) are written out here from
study.md rather than taken from the planner, so a planner bug cannot hide in shared code.
"""

from __future__ import annotations

from collections import Counter
from itertools import pairwise, permutations
from pathlib import Path
from typing import Any

import pytest

from chameleons.experiment.design import PlanRow, plan
from chameleons.experiment.study import load_default_study, load_study
from tests.experiment.study_files import four_condition_document, write_study

CONDITIONS = ["still", "natural", "copy"]
ACTORS = {"m1": "male", "m2": "male", "f1": "female", "f2": "female"}
FACES = ["face-1", "face-2", "face-3", "face-4"]
LUNAR = [
    "oxygen", "water", "stellar_map", "food_concentrate", "fm_transceiver", "nylon_rope",
    "first_aid_kit", "parachute_silk", "life_raft", "signal_flares", "pistols",
    "dehydrated_milk", "heating_unit", "magnetic_compass", "matches",
]  # fmt: skip
DESERT = [
    "cosmetic_mirror", "topcoat", "water", "flashlight", "parachute", "jackknife",
    "plastic_raincoat", "pistol", "sunglasses", "compress_kit", "magnetic_compass", "air_map",
    "edible_animals_book", "vodka", "salt_tablets",
]  # fmt: skip
# Middle ten by expert rank (3-12): upper five "better", lower five "worse".
SCENARIO_ITEMS = {
    ("lunar", "better"): set(LUNAR[2:7]),
    ("lunar", "worse"): set(LUNAR[7:12]),
    ("desert", "better"): set(DESERT[2:7]),
    ("desert", "worse"): set(DESERT[7:12]),
}


def assert_balanced(counts: Counter[Any], cells: list[Any], ideal: float, exact: bool) -> None:
    for cell in cells:
        if exact:
            assert counts[cell] == ideal, (cell, counts[cell], ideal)
        else:
            assert abs(counts[cell] - ideal) <= 1, (cell, counts[cell], ideal)
    assert set(counts) <= set(cells), set(counts) - set(cells)


def verify(rows: list[PlanRow], exact: bool) -> None:
    """study.md's eight constraints for the default study."""
    n = len(rows)
    assert [row.participant for row in rows] == list(range(1, n + 1))
    slots = [(p, i) for row in rows for p, i in enumerate(row.interactions, start=1)]
    for row in rows:
        interactions = row.interactions
        assert [i.position for i in interactions] == [1, 2, 3]
        assert sorted(i.condition for i in interactions) == sorted(CONDITIONS)
        # 3: three distinct actors; 7: three distinct faces; 4: no scenario twice.
        assert len({i.actor for i in interactions}) == 3
        assert len({i.face for i in interactions}) == 3
        assert len({(i.task, i.item_set) for i in interactions}) == 3
        # 5: never the same task type twice in a row.
        assert all(a.task != b.task for a, b in pairwise(interactions))
        # Three different robot names per session.
        assert len({i.robot_name for i in interactions}) == 3
        for i in interactions:
            assert sorted(i.item_order) == sorted(SCENARIO_ITEMS[(i.task, i.item_set)])
    # 1: each condition first, middle and last equally often.
    by_position = Counter((i.condition, p) for p, i in slots)
    assert_balanced(by_position, [(c, p) for c in CONDITIONS for p in (1, 2, 3)], n / 3, exact)
    # 2: each condition with each actor equally often.
    with_actor = Counter((i.condition, i.actor) for _, i in slots)
    assert_balanced(with_actor, [(c, a) for c in CONDITIONS for a in ACTORS], n / 4, exact)
    # 3: every actor (and so each gender) equally often.
    actors = Counter(i.actor for _, i in slots)
    assert_balanced(actors, list(ACTORS), 3 * n / 4, exact)
    genders = Counter(ACTORS[i.actor] for _, i in slots)
    assert_balanced(genders, ["male", "female"], 3 * n / 2, exact)
    # 4 and 6: every scenario (= item set x task type) equally often.
    scenarios = Counter((i.task, i.item_set) for _, i in slots)
    assert_balanced(scenarios, list(SCENARIO_ITEMS), 3 * n / 4, exact)
    # 7: every face equally often.
    assert_balanced(Counter(i.face for _, i in slots), list(FACES), 3 * n / 4, exact)
    # 8: each item first and last equally often per scenario (within 1), so at least once
    # each when the scenario was shown at least five times.
    for scenario, items in SCENARIO_ITEMS.items():
        shown = [i for _, i in slots if (i.task, i.item_set) == scenario]
        firsts = Counter(i.item_order[0] for i in shown)
        lasts = Counter(i.item_order[-1] for i in shown)
        assert_balanced(firsts, list(items), len(shown) / 5, exact=False)
        assert_balanced(lasts, list(items), len(shown) / 5, exact=False)
        if len(shown) >= 5:
            assert all(firsts[item] >= 1 and lasts[item] >= 1 for item in items)


def verify_williams(rows: list[PlanRow], conditions: list[str]) -> None:
    """Every run of len(sequences) rows holds each ordered adjacent pair equally often."""
    k = len(conditions)
    period = k if k % 2 == 0 else 2 * k
    assert len(rows) % period == 0
    for start in range(0, len(rows), period):
        chunk = rows[start : start + period]
        orders = [tuple(i.condition for i in row.interactions) for row in chunk]
        pairs = Counter(pair for order in orders for pair in pairwise(order))
        per_pair = period * (k - 1) // (k * (k - 1))
        assert pairs == dict.fromkeys(permutations(conditions, 2), per_pair), pairs
        positions = Counter((c, p) for order in orders for p, c in enumerate(order))
        assert set(positions.values()) == {period // k}


@pytest.mark.parametrize("participants", [12, 24, 36])
@pytest.mark.parametrize("seed", [0, 1, 2024])
def test_multiples_of_twelve_are_exact(participants: int, seed: int) -> None:
    result = plan(load_default_study(), participants, seed)
    verify(result.rows, exact=True)
    verify_williams(result.rows, CONDITIONS)


@pytest.mark.parametrize("participants", [*range(1, 12), 13, 17, 18, 23, 30, 41])
@pytest.mark.parametrize("seed", [0, 5])
def test_other_counts_are_within_one_of_ideal(participants: int, seed: int) -> None:
    verify(plan(load_default_study(), participants, seed).rows, exact=False)


def test_same_seed_same_plan_other_seed_other_plan() -> None:
    study = load_default_study()
    assert plan(study, 24, 7).rows == plan(study, 24, 7).rows
    assert plan(study, 24, 7).rows != plan(study, 24, 8).rows


@pytest.mark.parametrize(("first", "more"), [(1, 1), (5, 7), (12, 1), (13, 23), (24, 12)])
def test_extending_a_plan_keeps_its_rows(first: int, more: int) -> None:
    study = load_default_study()
    assert plan(study, first + more, 3).rows[:first] == plan(study, first, 3).rows


def test_four_conditions_get_a_generalised_williams_design(tmp_path: Path) -> None:
    study = load_study(write_study(tmp_path, four_condition_document()))
    conditions = list(study.condition_ids)
    rows = plan(study, 16, 11).rows
    verify_williams(rows, conditions)
    for row in rows:
        assert sorted(i.condition for i in row.interactions) == sorted(conditions)
        assert all(a.task != b.task for a, b in pairwise(row.interactions))
    with_actor = Counter((i.condition, i.actor) for row in rows for i in row.interactions)
    assert set(with_actor.values()) == {4}
    assert len(with_actor) == 16
