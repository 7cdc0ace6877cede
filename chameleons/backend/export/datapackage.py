"""``datapackage.json``: the export bundle as a Frictionless Data Package.

One tabular data resource per CSV table, with a Table Schema built from the codebook's
column definitions: types (``string``, ``integer``, ``number``, ``boolean`` as
``true``/``false``, ``datetime`` in ISO 8601 UTC), descriptions, units (seconds for the
``*_s`` durations, scale points for the scores), allowed values (the study's conditions,
items, kinds, ...) and ranges, primary keys and foreign keys to ``participants``. Any
Frictionless tool (``frictionless validate datapackage.json``) checks the files against
it.
"""

from __future__ import annotations

import re
from typing import Any

from chameleons import __version__
from chameleons.backend.export.columns import Column, TableSpec
from chameleons.backend.models import Study
from chameleons.experiment.model import Study as StudySpec

PRIMARY_KEYS = {
    "participants": ["participant"],
    "interactions": ["participant", "session", "position"],
    "suggestions": ["participant", "session", "position", "index"],
    "questionnaire": ["participant", "session", "position", "questionnaire", "item"],
    "events": ["event"],
}
RANGE = re.compile(r"^(-?\d+)\.\.(-?\d+)$")


def allowed_values(spec: StudySpec) -> dict[tuple[str, str], list[str]]:
    """(table, column) whose values the study fixes, beyond those the codebook lists."""
    survival = list(dict.fromkeys(item.id for task in spec.tasks for item in task.items))
    answers = list(dict.fromkeys(i.id for q in spec.questionnaires for i in q.items))
    return {("suggestions", "item"): survival, ("questionnaire", "item"): answers}


def field(column: Column, spec: StudySpec, table: str = "") -> dict[str, Any]:
    descriptor: dict[str, Any] = {
        "name": column.name,
        "type": column.type,
        "description": column.description,
    }
    if column.type == "boolean":
        descriptor.update(trueValues=["true"], falseValues=["false"])
    if column.type == "datetime":
        descriptor["format"] = "default"
    constraints = _constraints(column, spec, table)
    if constraints:
        descriptor["constraints"] = constraints
    unit = _unit(column)
    if unit:
        descriptor["unit"] = unit
    if column.identifying:
        descriptor["possiblyIdentifying"] = True
    return descriptor


def _constraints(column: Column, spec: StudySpec, table: str) -> dict[str, Any]:
    values = column.values.strip()
    match = RANGE.match(values)
    if match and column.type in {"integer", "number"}:
        low, high = int(match.group(1)), int(match.group(2))
        return {"minimum": low, "maximum": high}
    if column.type == "string" and values and ".." not in values:
        return {"enum": [v.strip() for v in values.split(",") if v.strip()]}
    fixed = allowed_values(spec).get((table, column.name))
    if column.type == "string" and fixed:
        return {"enum": fixed}
    return {}


def _unit(column: Column) -> str | None:
    if column.name.endswith("_s"):
        return "s"
    if column.name.endswith("_error"):
        return "rank places"
    if column.type == "number" and RANGE.match(column.values.strip()):
        return "scale points"
    if column.name in {"accepted", "suggestions_decided"} and column.type == "integer":
        return "suggestions"
    return None


def schema(table: TableSpec, spec: StudySpec) -> dict[str, Any]:
    result: dict[str, Any] = {
        "fields": [field(c, spec, table.name) for c in table.columns],
        "missingValues": [""],
    }
    if table.name in PRIMARY_KEYS:
        result["primaryKey"] = PRIMARY_KEYS[table.name]
    if table.name != "participants" and "participant" in table.column_names:
        result["foreignKeys"] = [
            {
                "fields": ["participant"],
                "reference": {"resource": "participants", "fields": ["participant"]},
            }
        ]
    if table.name == "suggestions":
        result["foreignKeys"].append(
            {
                "fields": ["participant", "session", "position"],
                "reference": {
                    "resource": "interactions",
                    "fields": ["participant", "session", "position"],
                },
            }
        )
    return result


def datapackage(study: Study, spec: StudySpec, tables: list[TableSpec]) -> dict[str, Any]:
    return {
        "profile": "tabular-data-package",
        "name": re.sub(r"[^a-z0-9._-]+", "-", f"chameleons-study-{study.id}-{spec.id}".lower()),
        "title": f"{study.name}: export of study {study.id}",
        "description": spec.description,
        "version": study.config_hash[:12],
        "created_with": f"mechanical-chameleons {__version__}",
        "study_config_hash": study.config_hash,
        "resources": [
            {
                "name": table.name,
                "path": f"{table.name}.csv",
                "profile": "tabular-data-resource",
                "format": "csv",
                "mediatype": "text/csv",
                "encoding": "utf-8",
                "description": table.description,
                "schema": schema(table, spec),
            }
            for table in tables
        ],
    }
