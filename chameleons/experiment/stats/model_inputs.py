"""The acceptance model's rows: the export's suggestions with their interaction's item set
and planned condition.

Both ways into the analysis use this one join: the database (the export's row generators)
and an exported bundle (``suggestions.csv`` + ``interactions.csv``), so they cannot differ.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

MODEL_COLUMNS = (
    "participant", "session", "position", "condition", "kind", "accepted", "direction",
)  # fmt: skip
FROM_INTERACTION = ("item_set", "planned_condition")


def suggestions_with_item_set(
    suggestions: Iterable[Mapping[str, Any]], interactions: Iterable[Mapping[str, Any]]
) -> list[dict[str, Any]]:
    """One row per suggestion with the model's columns; ``item_set`` and
    ``planned_condition`` (for the as-planned view) come from the interaction with the same
    participant, session and position."""
    extra = {_key(row): {c: row.get(c) for c in FROM_INTERACTION} for row in interactions}
    empty = dict.fromkeys(FROM_INTERACTION)
    return [
        {**{column: row.get(column) for column in MODEL_COLUMNS}, **extra.get(_key(row), empty)}
        for row in suggestions
    ]


def _key(row: Mapping[str, Any]) -> tuple[str, str, str]:
    return (str(row.get("participant")), str(row.get("session")), str(row.get("position")))
