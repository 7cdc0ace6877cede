"""Tables of survival-task error scores per condition (e.g. before and after negotiating)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from chameleons.experiment.stats.analysis import AnalysisError, order_conditions
from chameleons.experiment.stats.descriptive import Descriptive, describe

ERROR_COLUMNS = ("initial_error", "final_error")


def error_score_table(
    rows: Iterable[Mapping[str, Any]],
    *,
    columns: Sequence[str] = ERROR_COLUMNS,
    condition_order: Sequence[str] | None = None,
) -> dict[str, dict[str, Descriptive]]:
    """Descriptives per condition of each error column, plus ``error_change`` (final minus
    initial) when both of the default columns are there. Rows: ``condition`` + columns;
    empty values are skipped."""
    values: dict[str, dict[str, list[float]]] = {}
    for number, row in enumerate(rows, start=1):
        condition = str(row.get("condition", "")).strip()
        if not condition:
            raise AnalysisError(f"row {number}: no condition")
        present = {c: _value(row.get(c), number, c) for c in columns}
        if set(ERROR_COLUMNS) <= set(columns):
            initial, final = present["initial_error"], present["final_error"]
            present["error_change"] = None if initial is None or final is None else final - initial
        for column, value in present.items():
            if value is not None:
                values.setdefault(column, {}).setdefault(condition, []).append(value)
    conditions = order_conditions(
        {c for per_condition in values.values() for c in per_condition}, condition_order
    )
    return {
        column: {c: describe(per_condition.get(c, [])) for c in conditions}
        for column, per_condition in values.items()
    }


def _value(value: object, number: int, column: str) -> float | None:
    if value is None or str(value).strip() == "":
        return None
    try:
        return float(str(value))
    except ValueError:
        raise AnalysisError(f"row {number}, {column}: {value!r} is not a number") from None
