"""What an export column is (``Column``, ``TableSpec``) and the columns several of the
export's tables share (the participant, the session, the position, the condition, a time,
a list of items, the exclusion, the negotiation's counts, the language).

Column names are stable API (R and pandas scripts use them): add columns, never rename.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from chameleons.experiment.model import Study as StudySpec

ColumnType = Literal["string", "integer", "number", "boolean", "datetime"]
LIST_SEPARATOR = ";"
TIME_NOTE = (
    "ISO 8601 in UTC with millisecond precision, e.g. 2026-03-02T09:00:00.000+00:00; in"
    " data.xlsx an Excel date-time in UTC (Excel stores no time zone)"
)


@dataclass(frozen=True)
class Column:
    name: str
    type: ColumnType
    description: str
    values: str = ""
    identifying: bool = False


@dataclass(frozen=True)
class TableSpec:
    name: str
    description: str
    columns: tuple[Column, ...]

    @property
    def column_names(self) -> list[str]:
        return [column.name for column in self.columns]


def participant_column() -> Column:
    return Column("participant", "string", "Pseudonymous participant code (no names are stored).")


def session_column() -> Column:
    return Column("session", "integer", "Session id (a participant normally has one session).")


def position_column(spec: StudySpec) -> Column:
    k = spec.interactions_per_session
    return Column("position", "integer", "Interaction position in the session.", f"1..{k}")


def condition_column(spec: StudySpec, what: str = "Condition actually run.") -> Column:
    return Column("condition", "string", what, ", ".join(spec.condition_ids))


def time_column(name: str, what: str) -> Column:
    return Column(name, "datetime", f"{what} ({TIME_NOTE}).")


def list_column(name: str, what: str) -> Column:
    return Column(name, "string", f"{what}; item ids joined by '{LIST_SEPARATOR}', first = rank 1.")


def exclusion_columns() -> tuple[Column, Column]:
    return (
        Column(
            "excluded",
            "boolean",
            "The PI excluded the participant from the analysis (data kept): every analysis"
            " view leaves them out and says why.",
        ),
        Column(
            "exclusion_reason",
            "string",
            "The PI's reason for the exclusion. POSSIBLY IDENTIFYING (free text).",
            identifying=True,
        ),
    )


def decided_column(spec: StudySpec) -> Column:
    n = spec.suggestions_per_interaction
    return Column(
        "suggestions_decided",
        "integer",
        f"How many of the interaction's {n} suggestions were decided (accepted or declined);"
        f" below {n}: the negotiation was not finished.",
        f"0..{n}",
    )


def interaction_status_column() -> Column:
    return Column(
        "interaction_status",
        "string",
        "complete: every step done; partial: started but not finished (e.g. the session"
        " ended early); not_run: never started (missing, not zero).",
        "complete, partial, not_run",
    )


def accepted_column(spec: StudySpec, what: str) -> Column:
    n = spec.suggestions_per_interaction
    return Column(
        "accepted",
        "integer",
        f"{what} MISSING (empty) unless all {n} suggestions were decided: an interaction that"
        " never ran or stopped early has no count (never 0).",
        f"0..{n}",
    )


def language_column(description: str, spec: StudySpec) -> Column:
    return Column("language", "string", description, ", ".join(spec.languages))
