"""SPSS (.sav) and Stata (.dta) files of the export tables, through pyreadstat.

Every variable gets the codebook's description as its label. Columns with a known set of
values become labelled integers, as SPSS and Stata users expect: conditions (and planned
conditions) with the study's condition labels, the survival-task items with their names,
tasks, item sets, actors, faces, questionnaires, suggestion kinds, statuses, and booleans
(0 = false, 1 = true). The questionnaire's raw answers carry the scale's anchors as value
labels. Times are UTC without a zone (both formats have none; the label says UTC).
Missing numbers are system-missing; a missing text is an empty string (Stata has no
missing string).
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import IO, TYPE_CHECKING, Literal

from chameleons.backend.export.columns import Column, TableSpec
from chameleons.experiment.model import Study as StudySpec

if TYPE_CHECKING:  # pandas is imported where it is used: the CLI starts faster
    import pandas as pd

StatFormat = Literal["sav", "dta"]
STATA_LABEL = 80  # Stata's variable labels are at most 80 characters
SPSS_LABEL = 256
BOOLEAN_LABELS = {0: "false", 1: "true"}


def value_labels(spec: StudySpec) -> dict[str, dict[str, str]]:
    """Column name -> (value -> label) for the columns whose values the study defines."""
    conditions = {c.id: c.label for c in spec.conditions}
    return {
        "condition": conditions,
        "planned_condition": conditions,
        "item": {item.id: item.name for task in spec.tasks for item in task.items},
        "task": {task.id: task.name for task in spec.tasks},
        "item_set": {s: s for s in spec.item_sets.sets},
        "actor": {actor.id: actor.name for actor in spec.actors},
        "actor_gender": {"female": "female", "male": "male"},
        "face": {face.id: face.label for face in spec.faces},
        "questionnaire": {q.id: q.title for q in spec.questionnaires},
        "kind": {
            "optimal": "optimal (towards the expert order)",
            "random": "random (fallback: nothing useful left)",
        },
    }


def answer_labels(spec: StudySpec) -> dict[int, str]:
    """The questionnaire answers' scale ends: agreement anchors and, for semantic
    differentials, "left/right anchor" (each item has its own words there)."""
    scored = [q for q in spec.questionnaires if q.scored]
    if not scored:
        return {}
    points = scored[0].points
    lows = list(dict.fromkeys(q.low for q in scored if q.low))
    highs = list(dict.fromkeys(q.high for q in scored if q.high))
    if any(item.type == "differential" for q in scored for item in q.numeric_items):
        lows.append("the item's left anchor")
        highs.append("the item's right anchor")
    return {1: "1 = " + " / ".join(lows), points: f"{points} = " + " / ".join(highs)}


def _label(column: Column, limit: int) -> str:
    text = column.description
    if column.type == "datetime":
        text = text.split(" (ISO")[0] + " (UTC)"
    if len(text) <= limit:
        return text
    sentence = text.split(". ")[0].rstrip(".")
    return sentence if len(sentence) <= limit else sentence[: limit - 1].rstrip() + "…"


def labelled_frame(
    table: TableSpec, data: pd.DataFrame, spec: StudySpec, fmt: StatFormat
) -> tuple[pd.DataFrame, dict[str, str], dict[str, dict[float, str]]]:
    """The frame as the file stores it, its variable labels and its value labels."""
    import pandas as pd

    known = value_labels(spec)
    limit = STATA_LABEL if fmt == "dta" else SPSS_LABEL
    out: dict[str, pd.Series] = {}
    labels: dict[str, dict[float, str]] = {}
    for column in table.columns:
        series = data[column.name]
        if column.type == "boolean":
            out[column.name] = series.astype("Float64").astype("float64")
            labels[column.name] = {float(k): v for k, v in BOOLEAN_LABELS.items()}
        elif column.type == "string" and column.name in known:
            codes, names = _encode(series, known[column.name])
            out[column.name] = codes
            labels[column.name] = names
        elif column.type == "string":
            out[column.name] = series.astype(object).where(series.notna(), "")
        elif column.type == "integer":
            out[column.name] = series.astype("Float64").astype("float64")
            if column.name == "value" and table.name == "questionnaire":
                labels[column.name] = {float(k): v for k, v in answer_labels(spec).items()}
        elif column.type == "datetime":
            out[column.name] = series.dt.tz_convert("UTC").dt.tz_localize(None)
        else:
            out[column.name] = series.astype("float64")
    variable_labels = {c.name: _label(c, limit) for c in table.columns}
    return pd.DataFrame(out, columns=table.column_names), variable_labels, labels


def _encode(series: pd.Series, known: dict[str, str]) -> tuple[pd.Series, dict[float, str]]:
    """Codes 1, 2, ... in the study's order; values the study does not list get the next
    codes and label themselves (nothing is lost)."""
    import pandas as pd

    order = list(known) + sorted({str(v) for v in series.dropna()} - set(known))
    codes = {value: float(number) for number, value in enumerate(order, start=1)}
    encoded = series.map(lambda v: codes[str(v)] if pd.notna(v) else float("nan"))
    return encoded.astype("float64"), {codes[v]: known.get(v, v) for v in order}


def write_statfile(
    stream: IO[bytes], table: TableSpec, data: pd.DataFrame, spec: StudySpec, fmt: StatFormat
) -> None:
    import pyreadstat  # only SPSS/Stata exports need it

    stored, labels, values = labelled_frame(table, data, spec, fmt)
    variable_labels: dict[str, str | None] = dict(labels)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{table.name}.{fmt}"
        if fmt == "sav":
            pyreadstat.write_sav(stored, path, column_labels=variable_labels,
                                 variable_value_labels=values)  # fmt: skip
        else:
            pyreadstat.write_dta(stored, path, column_labels=variable_labels,
                                 variable_value_labels=values, version=15)  # fmt: skip
        stream.write(path.read_bytes())
