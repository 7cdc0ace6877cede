"""Adapter between the experiment core's planner and the stored plan rows (plain JSON)."""

from __future__ import annotations

from typing import Any

from chameleons.experiment import design
from chameleons.experiment.model import Study

PLANNED_FIELDS = (
    "position",
    "condition",
    "actor",
    "face",
    "robot_name",
    "task",
    "item_set",
    "item_order",
)


def planned_rows(spec: Study, participants: int, seed: int) -> list[list[dict[str, Any]]]:
    """One list of planned interactions (JSON-able dicts) per participant, in row order."""
    plan = design.plan(spec, participants, seed)
    return [
        [_interaction_dict(interaction) for interaction in row.interactions] for row in plan.rows
    ]


def _interaction_dict(interaction: object) -> dict[str, Any]:
    values = {name: getattr(interaction, name) for name in PLANNED_FIELDS}
    values["position"] = int(values["position"])
    values["item_order"] = [str(item) for item in values["item_order"]]
    return values
