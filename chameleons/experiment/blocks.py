"""One balance period ("block") of plan rows for a study: conditions, actors, scenarios, faces.

The pieces are searched one after the other because, with the condition orders fixed,
the actor, scenario and face choices constrain each other only through the conditions:
- condition orders: Williams sequences, each used equally often; condition x position and
  adjacent ordered pairs (carry-over) even;
- actors: distinct within a session; actor uses and condition x actor pairs even;
- scenarios: distinct within a session, task types alternating (when the study asks for
  it); scenario uses and condition x scenario pairs even;
- faces: distinct within a session; face uses and condition x face pairs even; with
  ``personas.match_gender`` only faces whose gender fits the position's voice; with
  ``personas.faces: per_actor`` no search at all: each actor brings its own face.
"""

from __future__ import annotations

import itertools
import math
import random
from dataclasses import dataclass
from fractions import Fraction

from chameleons.experiment.balanced_search import Option, SearchResult, Tally, find_block
from chameleons.experiment.model import Study
from chameleons.experiment.personas import compatible
from chameleons.experiment.williams import williams_sequences


class PlanError(ValueError):
    """The study's design cannot be planned (e.g. no valid scenario sequence exists)."""


@dataclass(frozen=True)
class BlockRow:
    """Indices into the study's conditions, actors, scenarios and faces, per position."""

    conditions: tuple[int, ...]
    actors: tuple[int, ...]
    scenarios: tuple[int, ...]
    faces: tuple[int, ...]


@dataclass(frozen=True)
class Block:
    rows: list[BlockRow]
    modes: dict[str, str]  # per piece: strict | loose | greedy (see balanced_search)


def balance_period(study: Study) -> int:
    """Rows after which every balance count can be exact (a multiple of each denominator)."""
    k = study.interactions_per_session
    faces = len(study.faces) if study.personas.faces == "independent" else 1
    return math.lcm(len(williams_sequences(k)), len(study.actors), faces, len(study.scenarios))


def scenario_sequences(study: Study) -> list[tuple[int, ...]]:
    """All orders of distinct scenarios for one session that respect task alternation."""
    k = study.interactions_per_session
    tasks = [s.task for s in study.scenarios]
    valid = [
        seq
        for seq in itertools.permutations(range(len(tasks)), k)
        if not study.alternate_tasks
        or all(tasks[a] != tasks[b] for a, b in itertools.pairwise(seq))
    ]
    if not valid:
        raise PlanError(
            f"no order of {k} distinct scenarios avoids the same task twice in a row; "
            "add item sets or tasks, or set design.alternate_tasks to false"
        )
    return valid


def build_block(
    study: Study, rng: random.Random, face_of_actor: dict[int, int] | None = None
) -> Block:
    """One block of rows; ``face_of_actor`` (actor index -> face index) when faces are
    tied to actors (``personas.faces: per_actor``)."""
    rows = balance_period(study)
    k = study.interactions_per_session
    relabel = list(range(k))
    rng.shuffle(relabel)  # a random Williams square of the family
    sequences = [tuple(relabel[c] for c in seq) for seq in williams_sequences(k)]
    conditions_found = _search_conditions(sequences, k, rows, rng)
    conditions = [sequences[value[0]] for value in conditions_found.values]
    scenario_options = scenario_sequences(study)
    actor_orders = _all_orders(len(study.actors), k)
    actors = _search_assignment(conditions, len(study.actors), [actor_orders] * rows, rng)
    if face_of_actor is not None:
        faces = SearchResult([tuple(face_of_actor[a] for a in row) for row in actors.values],
                             "strict")  # fmt: skip
    else:
        face_orders = [_face_orders(study, row) for row in actors.values]
        faces = _search_assignment(conditions, len(study.faces), face_orders, rng)
    # With alternating tasks, condition x scenario cannot also be even on every prefix
    # (the middle position always gets the session's minority task): exact per block only.
    scenarios = _search_assignment(
        conditions, len(study.scenarios), [scenario_options] * rows, rng, pairs_on_the_way=False
    )
    block_rows = [
        BlockRow(conditions[r], actors.values[r], scenarios.values[r], faces.values[r])
        for r in range(rows)
    ]
    modes = {
        "conditions": conditions_found.mode,
        "actors": actors.mode,
        "scenarios": scenarios.mode,
        "faces": faces.mode,
    }
    return Block(block_rows, modes)


def _search_conditions(
    sequences: list[tuple[int, ...]], k: int, rows: int, rng: random.Random
) -> SearchResult:
    tallies = [
        Tally("sequence", Fraction(1, len(sequences)), list(range(len(sequences)))),
        Tally("condition_position", Fraction(1, k), list(itertools.product(range(k), range(k)))),
        # Carry-over balance exists only per full Williams design (two rows of three
        # conditions cannot be even in positions and in adjacent pairs at once).
        Tally("carry_over", Fraction(1, k), list(itertools.permutations(range(k), 2)), False),
    ]
    options = [
        Option(
            (
                (0, index),
                *((1, (c, p)) for p, c in enumerate(seq)),
                *((2, pair) for pair in itertools.pairwise(seq)),
            ),
            (index,),
        )
        for index, seq in enumerate(sequences)
    ]
    return find_block([options] * rows, tallies, rng)


def _all_orders(n: int, k: int) -> list[tuple[int, ...]]:
    return list(itertools.permutations(range(n), k))


def _face_orders(study: Study, actors: tuple[int, ...]) -> list[tuple[int, ...]]:
    """Distinct faces for a row whose voices are ``actors``; with ``match_gender`` only
    faces whose gender fits each position's voice."""
    orders = _all_orders(len(study.faces), len(actors))
    if not study.personas.match_gender:
        return orders
    voices = [study.actors[a].gender for a in actors]
    faces = [f.gender for f in study.faces]
    return [
        order
        for order in orders
        if all(compatible(v, faces[f]) for v, f in zip(voices, order, strict=True))
    ]


def _search_assignment(
    conditions: list[tuple[int, ...]],
    n: int,
    orders_per_row: list[list[tuple[int, ...]]],
    rng: random.Random,
    *,
    pairs_on_the_way: bool = True,
) -> SearchResult:
    """Give each position of each row one of ``n`` things (``orders_per_row``: per row the
    allowed tuples, distinct things) so that uses and condition x thing pairs are even."""
    k = len(conditions[0])
    tallies = [
        Tally("uses", Fraction(k, n), list(range(n))),
        Tally(
            "with_condition",
            Fraction(1, n),
            list(itertools.product(range(k), range(n))),
            pairs_on_the_way,
        ),
    ]
    options_per_row = [
        [
            Option(
                (*((0, t) for t in order), *((1, (c, t)) for c, t in zip(row, order, strict=True))),
                order,
            )
            for order in orders
        ]
        for row, orders in zip(conditions, orders_per_row, strict=True)
    ]
    return find_block(options_per_row, tallies, rng)
