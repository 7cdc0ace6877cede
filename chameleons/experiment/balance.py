"""How balanced a set of plan rows is: one count table per constraint of study.md.

Computed from the rows alone (any rows: a fresh plan, or the rows actually used so far),
never from the planner's own bookkeeping. A table is ``ok`` when every count is within
less than 1 of its ideal (the best integer counts can do) and ``exact`` when every count
equals its ideal.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import Any, Protocol

from chameleons.experiment.model import Study
from chameleons.experiment.personas import compatible


class _Interaction(Protocol):
    @property
    def condition(self) -> str: ...
    @property
    def actor(self) -> str: ...
    @property
    def face(self) -> str: ...
    @property
    def task(self) -> str: ...
    @property
    def item_set(self) -> str: ...
    @property
    def item_order(self) -> Sequence[str]: ...
    @property
    def robot_name(self) -> str: ...


class _Row(Protocol):
    @property
    def interactions(self) -> Sequence[_Interaction]: ...


@dataclass(frozen=True)
class ConstraintBalance:
    id: str
    constraint: int  # number in study.md's list; 0 = an extra safeguard
    description: str
    counts: dict[str, int]
    ideal: float

    @property
    def max_deviation(self) -> float:
        return max((abs(c - self.ideal) for c in self.counts.values()), default=0.0)

    @property
    def ok(self) -> bool:
        return self.max_deviation < 1 - 1e-9

    @property
    def exact(self) -> bool:
        return self.max_deviation < 1e-9

    def to_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "constraint": self.constraint,
            "description": self.description,
            "counts": self.counts,
            "ideal": round(self.ideal, 6),
            "max_deviation": round(self.max_deviation, 6),
            "ok": self.ok,
            "exact": self.exact,
        }


@dataclass(frozen=True)
class BalanceReport:
    participants: int
    constraints: list[ConstraintBalance]

    @property
    def ok(self) -> bool:
        return all(c.ok for c in self.constraints)

    def problems(self) -> list[str]:
        return [
            f"{c.id}: a count is {c.max_deviation:.2f} away from its ideal {c.ideal:.2f}"
            for c in self.constraints
            if not c.ok
        ]

    def to_dict(self) -> dict[str, Any]:
        return {
            "participants": self.participants,
            "ok": self.ok,
            "constraints": [c.to_dict() for c in self.constraints],
        }


def balance_report(study: Study, rows: Iterable[_Row]) -> BalanceReport:
    sessions = [list(row.interactions) for row in rows]
    n, k = len(sessions), study.interactions_per_session
    slots = [i for s in sessions for i in s]
    conditions, actors = study.condition_ids, [a.id for a in study.actors]
    faces, scenarios = [f.id for f in study.faces], [s.id for s in study.scenarios]
    if study.personas.faces == "per_actor":  # only the faces the actors brought take part
        faces = [f for f in faces if any(i.face == f for i in slots)] or faces[: len(actors)]
    entries = [
        _table(
            "condition_position",
            1,
            "each condition equally often at each position",
            Counter(f"{i.condition}@{p}" for s in sessions for p, i in enumerate(s, 1)),
            [f"{c}@{p}" for c in conditions for p in range(1, k + 1)],
            n / k,
        ),
        _table(
            "carry_over",
            1,
            "each ordered pair of conditions equally often adjacent (Williams design; "
            "exact per full set of Williams sequences)",
            Counter(f"{a.condition}>{b.condition}" for s in sessions for a, b in pairwise(s)),
            [f"{a}>{b}" for a in conditions for b in conditions if a != b],
            n / k,
        ),
        _table(
            "condition_actor",
            2,
            "each condition equally often with each actor",
            Counter(f"{i.condition}/{i.actor}" for i in slots),
            [f"{c}/{a}" for c in conditions for a in actors],
            n / len(actors),
        ),
        _table(
            "actor",
            3,
            "each actor used equally often",
            Counter(i.actor for i in slots),
            actors,
            n * k / len(actors),
        ),
        _repeats("actor_repeated", 3, "sessions using an actor twice", sessions, "actor"),
        _table(
            "scenario",
            4,
            "each scenario shown equally often",
            Counter(f"{i.task}-{i.item_set}" for i in slots),
            scenarios,
            n * k / len(scenarios),
        ),
        _repeats("scenario_repeated", 4, "sessions showing a scenario twice", sessions, "scenario"),
    ]
    if study.alternate_tasks:
        twice = sum(any(a.task == b.task for a, b in pairwise(s)) for s in sessions)
        entries.append(
            ConstraintBalance(
                "task_twice_in_a_row",
                5,
                "sessions with the same task type twice in a row",
                {"sessions": twice},
                0.0,
            )
        )
    entries += [
        _table(
            "item_set_task",
            6,
            "each item set equally often with each task type",
            Counter(f"{i.item_set}/{i.task}" for i in slots),
            [f"{s.item_set}/{s.task}" for s in study.scenarios],
            n * k / len(scenarios),
        ),
        _table(
            "face",
            7,
            "each face used equally often",
            Counter(i.face for i in slots),
            faces,
            n * k / len(faces),
        ),
        _repeats("face_repeated", 7, "sessions using a face twice", sessions, "face"),
    ]
    entries += _first_last(study, slots)
    entries += _personas(study, slots)
    entries += [
        _table("condition_scenario", 0, "each condition equally often with each scenario "
               "(safeguard; exact per balance period)",
               Counter(f"{i.condition}/{i.task}-{i.item_set}" for i in slots),
               [f"{c}/{s}" for c in conditions for s in scenarios], n / len(scenarios)),
        _table("condition_face", 0, "each condition equally often with each face (safeguard)",
               Counter(f"{i.condition}/{i.face}" for i in slots),
               [f"{c}/{f}" for c in conditions for f in faces], n / len(faces)),
    ]  # fmt: skip
    return BalanceReport(n, entries)


def _personas(study: Study, slots: list[_Interaction]) -> list[ConstraintBalance]:
    """The persona setting kept: one name (face) per actor when fixed per actor; no face or
    name of another gender than its voice when genders are matched."""
    entries = []
    for what, fixed in (("robot_name", study.personas.names), ("face", study.personas.faces)):
        if fixed == "per_actor":
            used: dict[str, set[str]] = {}
            for i in slots:
                used.setdefault(i.actor, set()).add(str(getattr(i, what)))
            extra = sum(len(values) - 1 for values in used.values())
            taken = Counter(v for values in used.values() for v in values)
            shared = sum(count - 1 for count in taken.values())
            entries.append(ConstraintBalance(
                f"{what}_per_actor", 0, f"one {what.replace('_', ' ')} per actor, none shared "
                "(personas)", {"extra": extra, "shared": shared}, 0.0,
            ))  # fmt: skip
    if study.personas.match_gender:
        voices = {a.id: a.gender for a in study.actors}
        face_gender = {f.id: f.gender for f in study.faces}
        faces = sum(not compatible(voices.get(i.actor, ""), face_gender.get(i.face, ""))
                    for i in slots)  # fmt: skip
        names = sum(
            not compatible(voices.get(i.actor, ""), study.name_genders.get(i.robot_name, ""))
            for i in slots
        )
        entries.append(ConstraintBalance(
            "gender_mismatch", 0, "interactions whose face or name does not fit the voice's "
            "gender (personas.match_gender)", {"faces": faces, "names": names}, 0.0,
        ))  # fmt: skip
    return entries


def _table(
    name: str, number: int, text: str, counted: Counter[str], cells: list[str], ideal: float
) -> ConstraintBalance:
    counts = {cell: counted.get(cell, 0) for cell in cells}
    for cell, count in counted.items():  # values outside the study still show up
        counts.setdefault(cell, count)
    return ConstraintBalance(name, number, text, counts, ideal)


def _repeats(
    name: str, number: int, text: str, sessions: list[list[_Interaction]], what: str
) -> ConstraintBalance:
    def key(i: _Interaction) -> str:
        return f"{i.task}-{i.item_set}" if what == "scenario" else str(getattr(i, what))

    repeated = sum(len({key(i) for i in s}) < len(s) for s in sessions)
    return ConstraintBalance(name, number, text, {"sessions": repeated}, 0.0)


def _first_last(study: Study, slots: list[_Interaction]) -> list[ConstraintBalance]:
    """Per scenario: how often each item was shown first and last (ideal: shows / items).
    Within less than 1 of the ideal implies every item at least once first and once last
    as soon as the scenario was shown at least as often as it has items."""
    entries = []
    for scenario in study.scenarios:
        shown = [i for i in slots if (i.task, i.item_set) == (scenario.task, scenario.item_set)]
        counts = Counter(f"{i.item_order[0]} first" for i in shown if i.item_order)
        counts.update(f"{i.item_order[-1]} last" for i in shown if i.item_order)
        cells = [f"{item} {end}" for end in ("first", "last") for item in scenario.items]
        entries.append(
            _table(
                f"item_first_last:{scenario.id}",
                8,
                f"each item of {scenario.id} equally often first and last",
                counts,
                cells,
                len(shown) / len(scenario.items),
            )
        )
    return entries
