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

from chameleons.experiment.design import PlanRow, balance_period, plan
from chameleons.experiment.study import load_default_study, load_study
from tests.experiment.study_files import default_document, four_condition_document, write_study

CONDITIONS = ["still", "natural", "copy"]
ACTORS = {"m1": "male", "m2": "male", "f1": "female", "f2": "female"}
FACES = ["face-1", "face-2", "face-3", "face-4"]
# The default study's personas: what each demo face looks like and each name's gender.
FACE_GENDERS = {"face-1": "female", "face-2": "male", "face-3": "female", "face-4": "male"}
NAME_GENDERS = {
    "Nova": "female", "Iris": "female", "Luna": "female", "Vera": "female",
    "Milo": "male", "Theo": "male", "Oskar": "male", "Kai": "male",
}  # fmt: skip
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
    verify_personas(rows)


def verify_personas(rows: list[PlanRow]) -> None:
    """The default study's personas: one name per voice for the whole plan, distinct between
    voices; faces and names of the voice's gender only (match_gender)."""
    slots = [i for row in rows for i in row.interactions]
    names: dict[str, set[str]] = {}
    for i in slots:
        names.setdefault(i.actor, set()).add(i.robot_name)
        assert FACE_GENDERS[i.face] == ACTORS[i.actor], (i.actor, i.face)
        assert NAME_GENDERS[i.robot_name] == ACTORS[i.actor], (i.actor, i.robot_name)
    assert all(len(used) == 1 for used in names.values()), names
    assert len({name for used in names.values() for name in used}) == len(names)


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


def test_names_per_interaction_are_drawn_per_session_and_still_match_the_voice(
    tmp_path: Path,
) -> None:
    document = default_document()
    document["personas"]["names"] = "per_interaction"
    rows = plan(load_study(write_study(tmp_path, document)), 24, 3).rows
    by_actor: dict[str, set[str]] = {}
    for row in rows:
        assert len({i.robot_name for i in row.interactions}) == 3
        for i in row.interactions:
            assert NAME_GENDERS[i.robot_name] == ACTORS[i.actor]
            by_actor.setdefault(i.actor, set()).add(i.robot_name)
    assert all(len(names) > 1 for names in by_actor.values()), by_actor


def test_faces_tied_to_actors_give_every_voice_its_own_face(tmp_path: Path) -> None:
    document = default_document()
    document["personas"]["faces"] = "per_actor"
    rows = plan(load_study(write_study(tmp_path, document)), 12, 4).rows
    faces: dict[str, set[str]] = {}
    for i in (i for row in rows for i in row.interactions):
        faces.setdefault(i.actor, set()).add(i.face)
        assert FACE_GENDERS[i.face] == ACTORS[i.actor]
    assert all(len(used) == 1 for used in faces.values()), faces
    assert len({face for used in faces.values() for face in used}) == 4
    # Faces follow the actors, so they are used as evenly as the actors are.
    used = Counter(i.face for row in rows for i in row.interactions)
    assert set(used.values()) == {9}


def test_without_gender_match_faces_and_voices_combine_freely(tmp_path: Path) -> None:
    """The paper's "faces counterbalanced separately" on its own: over a plan every face
    appears with voices of both genders."""
    document = default_document()
    document["personas"]["match_gender"] = False
    rows = plan(load_study(write_study(tmp_path, document)), 24, 2).rows
    pairs = {(i.face, ACTORS[i.actor]) for row in rows for i in row.interactions}
    assert pairs == {(face, gender) for face in FACES for gender in ("male", "female")}


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


@pytest.mark.parametrize("k", [2, 3, 4, 5, 6])
def test_two_to_six_conditions_plan_balanced(tmp_path: Path, k: int) -> None:
    """Any number of conditions the loader allows plans one balance period on which every
    count of the balance report is exact, with a Williams design for the orders."""
    document = default_document()
    document["conditions"] = {
        f"c{n}": {"label": f"C{n}", "behaviour": "copy", "params": {"delay": float(n)}}
        for n in range(k)
    }
    people = max(4, k)
    gender = ["female", "male"]
    document["actors"] = {
        f"a{n}": {"name": f"A{n}", "gender": gender[n % 2], "voice": {"espeak": "en"}}
        for n in range(people)
    }
    document["faces"] = {
        f"face-{n}": {"label": f"F{n}", "gender": gender[n % 2]} for n in range(people)
    }
    document["robot_names"] = [{"name": f"N{n}", "gender": gender[n % 2]} for n in range(2 * k)]
    if k > 4:  # five or six distinct scenarios per session
        document["item_sets"] = {"first_rank": 1, "last_rank": 15, "sets": ["a", "b", "c"]}
    study = load_study(write_study(tmp_path, document))
    result = plan(study, balance_period(study), 1)
    conditions = list(study.condition_ids)
    assert result.notes == []
    # Every count exact, except where whole numbers cannot be (item first/last: within 1)
    # and "every item first and last once", which a short period cannot show yet.
    within = ("item_first_last", "carry_over")
    assert all(c.exact or (c.id.startswith(within) and c.ok)
               for c in result.balance.constraints if not c.id.startswith("item_at_ends")
               ), result.balance.problems()  # fmt: skip
    for row in result.rows:
        assert sorted(i.condition for i in row.interactions) == sorted(conditions)
    verify_williams(result.rows, conditions)
