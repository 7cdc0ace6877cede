"""The counterbalancing planner: one row per participant, one interaction per condition.

How a plan is made (all randomness from ``seed``; see docs/science.md):
- Rows come in blocks of the study's *balance period* (12 for the default study: the least
  common multiple of the number of Williams sequences, actors, faces and scenarios).
  Block ``b`` depends only on ``(seed, b)``, so a longer plan keeps the rows of a shorter
  one, and every count is exact at the end of each block.
- Inside a block the rows are searched so that after every row each count of study.md's
  constraints is within less than 1 of its ideal (see ``blocks``/``balanced_search``).
- Item orders: each scenario's k-th showing takes its first and last item from a cycle of
  random permutations (one per ``len(items)`` showings; first and last never the same
  item), so every item is first and last equally often (within 1); the middle is shuffled.
- Personas (``personas``): robot names fixed per actor (drawn once per seed; the paper) or
  drawn per row; faces counterbalanced on their own (the paper) or fixed per actor; with
  ``match_gender`` a face or name with a gender only goes with a voice of that gender.

Rows are handed out with :func:`next_free_row`; a withdrawn participant's row becomes free
again and goes to the next (replacement) participant, which keeps the balance.
"""

from __future__ import annotations

import random
from collections import Counter
from collections.abc import Collection
from dataclasses import asdict, dataclass
from functools import lru_cache
from typing import Any

from chameleons.experiment import personas
from chameleons.experiment.balance import BalanceReport, ConstraintBalance, balance_report
from chameleons.experiment.blocks import Block, PlanError, balance_period, build_block
from chameleons.experiment.model import Scenario, Study

__all__ = [
    "BalanceReport",
    "ConstraintBalance",
    "Plan",
    "PlanError",
    "PlanRow",
    "PlannedInteraction",
    "assign_row",
    "balance_period",
    "balance_report",
    "next_free_row",
    "plan",
    "plan_row",
    "plan_to_dict",
]


@dataclass(frozen=True)
class PlannedInteraction:
    position: int  # 1-based
    condition: str
    actor: str
    face: str
    robot_name: str
    task: str
    item_set: str
    item_order: list[str]  # the scenario's item ids in presentation order

    @property
    def scenario(self) -> str:
        return f"{self.task}-{self.item_set}"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class PlanRow:
    participant: int  # 1-based row number
    interactions: list[PlannedInteraction]

    def to_dict(self) -> dict[str, Any]:
        return {
            "participant": self.participant,
            "interactions": [i.to_dict() for i in self.interactions],
        }


@dataclass(frozen=True)
class Plan:
    study_id: str
    study_hash: str
    seed: int
    balance_period: int
    rows: list[PlanRow]
    balance: BalanceReport
    notes: list[str]


# The planner's algorithm version, exported with every data set: ``plan(study, n, seed)``
# gives the same rows for the same study, seed and planner version. Bump it with any change
# that would give different rows (tests/experiment/test_plan.py pins known rows).
PLANNER_VERSION = "1"


def plan(study: Study, participants: int, seed: int = 0) -> Plan:
    if participants < 0:
        raise PlanError("the number of participants cannot be negative")
    period = balance_period(study)
    blocks = [_block(study, seed, b) for b in range(-(-participants // period))]
    rows = _rows(study, seed, blocks)[:participants]
    notes = [
        f"block {b + 1}: {piece} could not be balanced on every prefix ({mode} fallback)"
        for b, block in enumerate(blocks)
        for piece, mode in block.modes.items()
        if mode != "strict"
    ]
    report = balance_report(study, rows)
    return Plan(study.id, study.content_hash, seed, period, rows, report, notes)


def plan_row(study: Study, seed: int, row_number: int) -> PlanRow:
    """One row of the plan (1-based), as ``plan(study, row_number, seed)`` would give it."""
    if row_number < 1:
        raise PlanError("plan rows are numbered from 1")
    return plan(study, row_number, seed).rows[-1]


def plan_to_dict(plan: Plan) -> dict[str, Any]:
    return {
        "study": {"id": plan.study_id, "hash": plan.study_hash},
        "seed": plan.seed,
        "balance_period": plan.balance_period,
        "rows": [row.to_dict() for row in plan.rows],
        "balance": plan.balance.to_dict(),
        "notes": plan.notes,
    }


def next_free_row(taken_rows: Collection[int]) -> int:
    """The lowest row number (from 1) no current participant holds. Rows of withdrawn
    participants are not in ``taken_rows``, so they are handed out again first."""
    row = 1
    while row in taken_rows:
        row += 1
    return row


def assign_row(taken_rows: Collection[int], *, replacing: int | None = None) -> int:
    """The row for a new participant; with ``replacing``, the withdrawn participant's row
    (an error if someone already holds it again)."""
    if replacing is None:
        return next_free_row(taken_rows)
    if replacing < 1:
        raise PlanError("plan rows are numbered from 1")
    if replacing in taken_rows:
        raise PlanError(f"row {replacing} is held by another participant")
    return replacing


@lru_cache(maxsize=128)
def _block(study: Study, seed: int, index: int) -> Block:
    face_of_actor = None
    if study.personas.faces == "per_actor":
        faces = actor_faces(study, seed)
        index_of = {face.id: number for number, face in enumerate(study.faces)}
        face_of_actor = {a: index_of[faces[actor.id]] for a, actor in enumerate(study.actors)}
    return build_block(study, random.Random(f"{seed}/block/{index}"), face_of_actor)


def actor_faces(study: Study, seed: int) -> dict[str, str]:
    """Actor id -> face id, for ``personas.faces: per_actor`` (one draw per seed)."""
    return personas.per_actor(
        study, seed, "faces", [f.id for f in study.faces], lambda f: study.face(f).gender
    )


def actor_names(study: Study, seed: int) -> dict[str, str]:
    """Actor id -> robot name, for ``personas.names: per_actor`` (one draw per seed)."""
    return personas.per_actor(
        study, seed, "names", study.robot_names, lambda n: study.name_genders.get(n, "")
    )


def _names(study: Study, seed: int, number: int, actors: list[str]) -> list[str]:
    if study.personas.names == "per_actor":
        fixed = actor_names(study, seed)
        return [fixed[actor] for actor in actors]
    rng = random.Random(f"{seed}/names/{number}")
    return personas.per_session(
        study, rng, actors, study.robot_names, lambda n: study.name_genders.get(n, "")
    )


def _rows(study: Study, seed: int, blocks: list[Block]) -> list[PlanRow]:
    scenarios = study.scenarios
    orders = _ItemOrders(seed)
    rows = []
    for number, row in enumerate((r for block in blocks for r in block.rows), start=1):
        names = _names(study, seed, number, [study.actors[a].id for a in row.actors])
        interactions = [
            PlannedInteraction(
                position=position,
                condition=study.conditions[row.conditions[position - 1]].id,
                actor=study.actors[row.actors[position - 1]].id,
                face=study.faces[row.faces[position - 1]].id,
                robot_name=names[position - 1],
                task=scenarios[row.scenarios[position - 1]].task,
                item_set=scenarios[row.scenarios[position - 1]].item_set,
                item_order=orders.next(scenarios[row.scenarios[position - 1]], number, position),
            )
            for position in range(1, len(row.conditions) + 1)
        ]
        rows.append(PlanRow(number, interactions))
    return rows


class _ItemOrders:
    """Presentation orders whose first and last items cycle evenly per scenario."""

    def __init__(self, seed: int) -> None:
        self.seed = seed
        self.shown: Counter[str] = Counter()

    def next(self, scenario: Scenario, row: int, position: int) -> list[str]:
        cycle, slot = divmod(self.shown[scenario.id], len(scenario.items))
        self.shown[scenario.id] += 1
        firsts, lasts = self._cycle(scenario, cycle)
        first, last = firsts[slot], lasts[slot]
        middle = [item for item in scenario.items if item not in (first, last)]
        random.Random(f"{self.seed}/items/{row}/{position}").shuffle(middle)
        return [first, *middle, last] if first != last else [first]

    def _cycle(self, scenario: Scenario, cycle: int) -> tuple[list[str], list[str]]:
        rng = random.Random(f"{self.seed}/first-last/{scenario.id}/{cycle}")
        firsts = list(scenario.items)
        rng.shuffle(firsts)
        lasts = list(firsts)
        while len(lasts) > 1 and any(a == b for a, b in zip(firsts, lasts, strict=True)):
            rng.shuffle(lasts)  # a derangement: first and last are never the same item
        return firsts, lasts
