"""The session flag of a copy interaction whose robot did not follow the participant as
configured (issue 32): the copy check of its synchrony failed."""

from __future__ import annotations

from collections.abc import Callable

from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import Interaction
from chameleons.backend.synchrony import repository

KIND = "synchrony"
AddFlag = Callable[[int, str, int | None, str, int | None], None]


def synchrony_flags(db: DbSession, interactions: list[Interaction], add: AddFlag) -> None:
    stored = repository.stored(db, [i.id for i in interactions])
    for interaction in interactions:
        row = stored.get(interaction.id)
        if row is not None and row.check == "failed":
            add(interaction.session_id, KIND, interaction.position,
                f"interaction {interaction.position} ({interaction.condition}): the copy "
                f"check failed. {row.check_reason}", None)  # fmt: skip
