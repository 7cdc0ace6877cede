"""The acceptance model's rows: the export's suggestions with their interaction's item set.

Both ways into the analysis use this one join: the database (the export's row generators)
and an exported bundle (``suggestions.csv`` + ``interactions.csv``), so they cannot differ.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

MODEL_COLUMNS = ("participant", "session", "position", "condition", "item_set", "kind", "accepted")


def suggestions_with_item_set(
    suggestions: Iterable[Mapping[str, Any]], interactions: Iterable[Mapping[str, Any]]
) -> list[dict[str, Any]]:
    """One row per suggestion with the model's columns; ``item_set`` comes from the
    interaction with the same participant, session and position."""
    item_sets = {_key(row): row.get("item_set") for row in interactions}
    return [
        {
            **{column: row.get(column) for column in MODEL_COLUMNS if column != "item_set"},
            "item_set": item_sets.get(_key(row)),
        }
        for row in suggestions
    ]


def _key(row: Mapping[str, Any]) -> tuple[str, str, str]:
    return (str(row.get("participant")), str(row.get("session")), str(row.get("position")))
