"""Reading score rows (the export's ``scores`` table) for the analysis, refusing what cannot
be analysed with a sentence that names the row, the column and the value.

Refused: a value that is not a finite number (``inf``, ``nan`` text: a missing value is an
empty cell or ``NA``), a value outside the measure's scale or not a whole number where one
is required, a questionnaire score that no set of answers can give (it is the mean of its
items' whole-number answers, so a multiple of 1/items: 4.42 is no mean of 12 answers), a
condition the study does not have (labels are case-sensitive: ``Copy`` is not ``copy``),
and two rows for the same participant and condition.

Which condition a row counts for depends on the *view*:

- ``as_planned`` (intention to treat, the default): the planned condition
  (``planned_condition``; files without that column fall back to ``condition``);
- ``as_run`` (per protocol): the condition actually run; a participant with any deviation
  from the plan is left out (and listed).

Participants marked ``excluded`` leave both views; they are listed with the reason.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

View = Literal["as_planned", "as_run"]
VIEWS: tuple[View, ...] = ("as_planned", "as_run")
DEFAULT_VIEW: View = "as_planned"
VIEW_TITLES = {
    "as_planned": "as planned (intention to treat)",
    "as_run": "as run (per protocol: participants with deviations left out)",
}
MISSING_TEXT = {"", "na"}
GRID_TOLERANCE = 1e-9  # relative: an exported mean (53/12 as 4.416666666666667) is on the grid
NOT_FINITE_TEXT = {"nan", "-nan", "+nan", "inf", "-inf", "+inf", "infinity", "-infinity"}
TRUE_TEXT = {"true", "1", "yes", "t"}
FALSE_TEXT = {"false", "0", "no", "f", "", "na"}
STATUS_TEXT = {
    "not_run": "interaction not run",
    "partial": "interaction only partly run",
}
SESSION_TEXT = {
    "ended_early": "the session was ended early",
    "not_started": "the session never started",
    "in_progress": "the session is still running",
}


class AnalysisError(ValueError):
    """The score rows cannot be analysed (e.g. a value is not a number)."""


@dataclass(frozen=True)
class Scale:
    """The values a measure can take: ``low``..``high``, whole numbers when ``integer``,
    multiples of ``1 / mean_of`` when it is the mean of ``mean_of`` whole-number answers."""

    low: float
    high: float
    integer: bool = False
    what: str = ""
    mean_of: int = 0

    def describe(self) -> str:
        kind = "whole numbers" if self.integer else "values"
        return f"{self.what or 'this measure'} takes {kind} from {self.low:g} to {self.high:g}"

    def off_grid(self, value: float) -> str | None:
        """Why ``value`` cannot be a mean of ``mean_of`` whole numbers (None when it can)."""
        if self.mean_of < 2:
            return None
        total = value * self.mean_of
        if abs(total - round(total)) <= GRID_TOLERANCE * max(1.0, abs(total)):
            return None
        below, above = math.floor(total), math.ceil(total)
        return (
            f"is not a mean of {self.mean_of} whole-number answers (the nearest are "
            f"{below}/{self.mean_of} = {below / self.mean_of:.4f} and {above}/{self.mean_of} = "
            f"{above / self.mean_of:.4f}); a rounded or edited score cannot be analysed: use "
            "the exported value"
        )


@dataclass(frozen=True)
class LeftOut:
    participant: str
    reason: str


@dataclass
class ScoreTable:
    """Values per (participant, condition of the view) and measure."""

    values: dict[tuple[str, str], dict[str, float | None]] = field(default_factory=dict)
    status: dict[tuple[str, str], str] = field(default_factory=dict)
    sessions: dict[str, str] = field(default_factory=dict)  # participant -> session status
    participants: list[str] = field(default_factory=list)  # analysed, in natural order
    left_out: list[LeftOut] = field(default_factory=list)  # whole participants, with why
    measures: set[str] = field(default_factory=set)  # measure columns present
    conditions: set[str] = field(default_factory=set)  # conditions found in the view
    notes: list[str] = field(default_factory=list)


@dataclass
class _Row:
    number: int
    participant: str
    condition: str
    planned: str | None
    position: str
    excluded: bool
    exclusion_reason: str
    deviation: bool
    status: str
    session: str
    values: dict[str, float | None]


@dataclass(frozen=True)
class Reader:
    measures: Sequence[str]
    conditions: Sequence[str] | None = None  # the study's condition ids; None: any
    scales: Mapping[str, Scale] = field(default_factory=dict)
    view: View = DEFAULT_VIEW
    row_name: str = "row"
    first_row: int = 1

    def read(self, rows: Iterable[Mapping[str, Any]]) -> ScoreTable:
        if self.view not in VIEWS:
            raise AnalysisError(f"unknown view {self.view!r}; use one of {', '.join(VIEWS)}")
        table = ScoreTable()
        parsed = []
        for number, row in enumerate(rows, self.first_row):
            parsed.append(self._row(number, row))
            table.measures.update(m for m in self.measures if m in row)
        has_planned = any(r.planned is not None for r in parsed)
        if self.view == "as_planned" and parsed and not has_planned:
            table.notes.append(
                "the rows have no planned_condition: 'as planned' uses the condition column"
            )
        out = self._left_out(parsed)
        table.left_out = [LeftOut(p, reason) for p, reason in out.items()]
        kept = [r for r in parsed if r.participant not in out]
        self._fill(table, kept)
        table.participants = sorted({r.participant for r in kept}, key=natural_order)
        return table

    # --- one row -----------------------------------------------------------------------------
    def _row(self, number: int, row: Mapping[str, Any]) -> _Row:
        where = f"{self.row_name} {number}"
        participant = _required(row, "participant", where)
        where = f"{where} (participant {participant})"
        condition = self._condition(row, "condition", where, required=True)
        assert condition is not None
        where = f"{self.row_name} {number} (participant {participant}, condition {condition})"
        planned = self._condition(row, "planned_condition", where, required=False)
        excluded = _boolean(row.get("excluded"), where, "excluded")
        deviation = _boolean(row.get("deviation"), where, "deviation")
        values = {m: self._value(row.get(m), where, m) for m in self.measures}
        return _Row(
            number,
            participant,
            condition,
            planned,
            _text(row.get("position")),
            excluded,
            _text(row.get("exclusion_reason")),
            deviation or (planned is not None and planned != condition),
            _text(row.get("interaction_status")),
            _text(row.get("session_status")),
            values,
        )

    def _condition(
        self, row: Mapping[str, Any], column: str, where: str, *, required: bool
    ) -> str | None:
        text = _text(row.get(column))
        if not text:
            if required:
                raise AnalysisError(f"{where}, column {column}: no value")
            return None
        if self.conditions is not None and text not in self.conditions:
            hint = next((c for c in self.conditions if c.lower() == text.lower()), None)
            known = ", ".join(self.conditions)
            extra = f"; did you mean {hint!r}? Labels are case-sensitive" if hint else ""
            raise AnalysisError(
                f"{where}, column {column}: {text!r} is not a condition of the study "
                f"({known}){extra}."
            )
        return text

    def _value(self, value: object, where: str, column: str) -> float | None:
        number = _number(value, where, column)
        if number is None:
            return None
        scale = self.scales.get(column)
        if scale is None:
            return number
        if scale.integer and not number.is_integer():
            raise AnalysisError(
                f"{where}, column {column}: {value!r} is not a whole number ({scale.describe()})."
            )
        if not scale.low <= number <= scale.high:
            raise AnalysisError(
                f"{where}, column {column}: {value!r} is outside {scale.low:g}..{scale.high:g} "
                f"({scale.describe()})."
            )
        why = scale.off_grid(number)
        if why:
            raise AnalysisError(f"{where}, column {column}: {value!r} {why}.")
        return number

    # --- participants ------------------------------------------------------------------------
    def _left_out(self, rows: list[_Row]) -> dict[str, str]:
        out: dict[str, str] = {}
        for row in rows:
            if row.excluded and row.participant not in out:
                why = f": {row.exclusion_reason}" if row.exclusion_reason else ""
                out[row.participant] = f"excluded by the PI{why}"
        if self.view == "as_run":
            deviating: dict[str, list[str]] = {}
            for row in rows:
                if row.deviation and row.participant not in out:
                    at = (
                        f"interaction {row.position}"
                        if row.position
                        else f"{self.row_name} {row.number}"
                    )
                    planned = f", planned {row.planned}" if row.planned else ""
                    deviating.setdefault(row.participant, []).append(
                        f"{at} ran {row.condition}{planned}"
                    )
            for participant, what in deviating.items():
                out[participant] = f"deviation from the plan ({'; '.join(what)})"
        return dict(sorted(out.items(), key=lambda item: natural_order(item[0])))

    def _fill(self, table: ScoreTable, rows: list[_Row]) -> None:
        first_row: dict[tuple[str, str], int] = {}
        for row in rows:
            condition = row.planned if self.view == "as_planned" and row.planned else row.condition
            key = (row.participant, condition)
            if key in first_row:
                counted = "planned" if self.view == "as_planned" and row.planned else "run"
                raise AnalysisError(
                    f"{self.row_name}s {first_row[key]} and {row.number}: participant "
                    f"{row.participant} has {condition} twice (as {counted}); each participant "
                    "needs one row per condition."
                )
            first_row[key] = row.number
            table.values[key] = row.values
            table.conditions.add(condition)
            if row.status:
                table.status[key] = row.status
            if row.session:
                table.sessions[row.participant] = row.session


def missing_reason(status: str) -> str:
    return STATUS_TEXT.get(status, "")


def session_reason(status: str) -> str:
    return SESSION_TEXT.get(status, "")


def natural_order(participant: str) -> tuple[int, int | str]:
    """Participants 2 before 10; codes that are not numbers after, alphabetically; P002
    before P010 (the number after a letter prefix)."""
    if participant.isdigit():
        return (0, int(participant))
    head = participant.rstrip("0123456789")
    tail = participant[len(head) :]
    if tail:
        return (1, f"{head}{int(tail):012d}")
    return (1, participant)


def _text(value: object) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return str(value).strip()


def _required(row: Mapping[str, Any], column: str, where: str) -> str:
    text = _text(row.get(column))
    if not text:
        raise AnalysisError(f"{where}, column {column}: no value")
    return text


def _boolean(value: object, where: str, column: str) -> bool:
    if value is None or isinstance(value, bool):
        return bool(value)
    text = _text(value).lower()
    if text in TRUE_TEXT:
        return True
    if text in FALSE_TEXT:
        return False
    raise AnalysisError(f"{where}, column {column}: {value!r} is not true or false")


def _number(value: object, where: str, column: str) -> float | None:
    """A finite number, or None for a missing value (empty, NA, None; a float NaN, which is
    how pandas holds a missing cell in memory)."""
    if value is None:
        return None
    if isinstance(value, bool):
        raise AnalysisError(f"{where}, column {column}: {value!r} is not a number")
    if isinstance(value, int | float):
        number = float(value)
        if math.isnan(number):
            return None
        if math.isinf(number):
            raise AnalysisError(f"{where}, column {column}: {value!r} is not a finite number")
        return number
    text = str(value).strip()
    if text.lower() in MISSING_TEXT:
        return None
    if text.lower() in NOT_FINITE_TEXT:
        raise AnalysisError(
            f"{where}, column {column}: {text!r} is not a finite number (leave the cell "
            "empty, or write NA, for a missing value)."
        )
    try:
        number = float(text)
    except ValueError:
        raise AnalysisError(f"{where}, column {column}: {text!r} is not a number") from None
    if not math.isfinite(number):
        raise AnalysisError(f"{where}, column {column}: {text!r} is not a finite number")
    return number
