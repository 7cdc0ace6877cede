"""How balanced a set of plan rows is: one count table per constraint of study.md.

Computed from the rows alone (any rows: a fresh plan, or the rows actually used so far),
never from the planner's own bookkeeping. Each table has a status:

- ``exact``: every count equals its ideal;
- ``within 1``: every count is within less than 1 of its ideal (the best whole numbers
  can do for a table on its own);
- ``minimal``: not within 1, but as even as is possible with this many rows given the
  constraints that come first (:mod:`.balance_bounds` proves the minimum);
- ``uneven``: more uneven than that (or than 1, where no minimum is known);
- ``cannot hold``: a requirement that no set of this many rows can meet (every item first
  and last at least once needs a scenario shown at least as often as it has items).

A table (and the report) is ``ok`` unless it is ``uneven`` or ``cannot hold``.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from itertools import pairwise
from typing import Any, Literal, Protocol

from chameleons.experiment.balance_bounds import carry_over_bound, condition_scenario_bound
from chameleons.experiment.model import Study
from chameleons.experiment.personas import compatible
from chameleons.experiment.stats.rounding import fmt

Status = Literal["exact", "within 1", "minimal", "uneven", "cannot hold"]
TOLERANCE = 1e-6


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
    lower_bound: float | None = None  # the smallest largest deviation possible, if known
    impossible: str = ""  # why the requirement cannot hold with these rows ("": it can)

    @property
    def max_deviation(self) -> float:
        return max((abs(c - self.ideal) for c in self.counts.values()), default=0.0)

    @property
    def within_one(self) -> bool:
        return self.max_deviation < 1 - 1e-9

    @property
    def exact(self) -> bool:
        return self.max_deviation < 1e-9

    @property
    def status(self) -> Status:
        if self.impossible:
            return "cannot hold"
        if self.exact:
            return "exact"
        if self.within_one:
            return "within 1"
        if self.lower_bound is not None and self.max_deviation <= self.lower_bound + TOLERANCE:
            return "minimal"
        return "uneven"

    @property
    def ok(self) -> bool:
        return self.status not in ("uneven", "cannot hold")

    def verdict(self) -> str:
        """The status in words (the plan command and the dashboard)."""
        if self.status == "minimal":
            return "minimal possible imbalance"
        if self.status == "uneven" and self.lower_bound is not None:
            return f"uneven (the minimum possible is {fmt(self.lower_bound, 2)})"
        if self.status == "cannot hold":
            return f"cannot hold: {self.impossible}"
        return self.status

    def to_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "constraint": self.constraint,
            "description": self.description,
            "counts": self.counts,
            "ideal": round(self.ideal, 6),
            "max_deviation": round(self.max_deviation, 6),
            "lower_bound": None if self.lower_bound is None else round(self.lower_bound, 6),
            "status": self.status,
            "verdict": self.verdict(),
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

    @property
    def minimal(self) -> list[ConstraintBalance]:
        """Tables that are as even as these rows allow, but not within 1."""
        return [c for c in self.constraints if c.status == "minimal"]

    def problems(self) -> list[str]:
        return [
            f"{c.id}: {c.impossible}"
            if c.impossible
            else f"{c.id}: a count is {fmt(c.max_deviation, 2)} away from its ideal "
            f"{fmt(c.ideal, 2)}"
            + (f" (the minimum possible is {fmt(c.lower_bound, 2)})" if c.lower_bound is not None
               else "")
            for c in self.constraints
            if not c.ok
        ]  # fmt: skip

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
    entries += _at_ends(study, slots, n)
    return BalanceReport(n, [_with_bound(study, n, entry) for entry in entries])


def balance_summary(report: BalanceReport) -> str:
    """One sentence on the whole report (the plan command and the dashboard)."""
    people = f"{report.participants} participant{'s' if report.participants != 1 else ''}"
    if report.participants == 0:
        return "Nothing has run yet: the counts fill in as sessions complete."
    if not report.ok:
        return f"Not every constraint holds with {people}:"
    if report.minimal:
        names = ", ".join(c.id for c in report.minimal)
        return (
            f"Every count is as even as possible with {people}; {names} cannot be within 1 "
            "of the ideal (minimal possible imbalance)."
        )
    return "Every count is as even as whole numbers allow."


BOUNDS = {"carry_over": carry_over_bound, "condition_scenario": condition_scenario_bound}


def _with_bound(study: Study, n: int, entry: ConstraintBalance) -> ConstraintBalance:
    """The provable minimum, for the tables that other constraints can keep from being
    within 1 (computed only when they are not)."""
    bound = BOUNDS.get(entry.id)
    if bound is None or entry.within_one:
        return entry
    return replace(entry, lower_bound=bound(study, n))


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


def _at_ends(study: Study, slots: list[_Interaction], n: int) -> list[ConstraintBalance]:
    """Constraint 8 as study.md words it: every item at least once first and at least once
    last. It cannot hold while a scenario has been shown fewer times than it has items."""
    entries = []
    for scenario in study.scenarios:
        shown = [i for i in slots if (i.task, i.item_set) == (scenario.task, scenario.item_set)]
        firsts = {i.item_order[0] for i in shown if i.item_order}
        lasts = {i.item_order[-1] for i in shown if i.item_order}
        counts = {
            "items never first": sum(item not in firsts for item in scenario.items),
            "items never last": sum(item not in lasts for item in scenario.items),
        }
        if n == 0:  # nothing has run: nothing missed yet (a fresh study is not uneven)
            counts = dict.fromkeys(counts, 0)
        impossible = ""
        if n > 0 and len(shown) < len(scenario.items):
            impossible = (
                f"with {n} participant{'s' if n != 1 else ''}, {scenario.id} is shown "
                f"{len(shown)} time{'s' if len(shown) != 1 else ''} for its "
                f"{len(scenario.items)} items, so not every item can be first and last"
            )
        entries.append(
            ConstraintBalance(
                f"item_at_ends:{scenario.id}",
                8,
                f"every item of {scenario.id} at least once first and at least once last",
                counts,
                0.0,
                impossible=impossible,
            )
        )
    return entries


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
