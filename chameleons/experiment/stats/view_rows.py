"""The rows the analysis reads under a view: which condition an interaction counts as
(``as_planned``: the plan's; ``as_run``: the one actually run) and the score and suggestion
rows the models fit, restricted to the participants the tests kept."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from chameleons.experiment.stats.scores import ScoreTable, View


def view_condition(row: Mapping[str, Any], view: View) -> str:
    planned = str(row.get("planned_condition") or "").strip()
    return planned if view == "as_planned" and planned else str(row.get("condition")).strip()


def view_conditions(rows: Iterable[Mapping[str, Any]], view: View) -> dict[tuple[str, str], str]:
    """(participant, position) -> the condition the view counts that interaction as."""
    return {
        (str(row.get("participant")).strip(), str(row.get("position")).strip()): (
            view_condition(row, view)
        )
        for row in rows
    }


def model_score_rows(
    rows: list[Mapping[str, Any]], table: ScoreTable, view: View, measures: Sequence[str]
) -> list[dict[str, Any]]:
    """The score rows the models use: the view's participants and conditions, the values
    as the tests read them (checked and parsed), and each row's position."""
    kept = set(table.participants)
    result = []
    for row in rows:
        participant = str(row.get("participant")).strip()
        if participant not in kept:
            continue
        condition = view_condition(row, view)
        values = table.values.get((participant, condition), {})
        result.append(
            {
                "participant": participant,
                "condition": condition,
                **({"position": row["position"]} if "position" in row else {}),
                **{m: values.get(m) for m in measures},
            }
        )
    return result


def model_suggestion_rows(
    rows: Iterable[Mapping[str, Any]], table: ScoreTable, view: View
) -> list[dict[str, Any]]:
    """Per-suggestion rows of the view's participants, conditions as the view counts them."""
    kept = set(table.participants)
    return [
        {**row, "condition": view_condition(row, view)}
        for row in rows
        if str(row.get("participant")).strip() in kept
    ]
