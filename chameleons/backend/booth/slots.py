"""Where an interaction runs (its study, session, position and booth), as the booth's
reactions to committed events read it (:mod:`chameleons.backend.booth.flows`)."""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy.orm import Session

from chameleons.backend.booth import repository
from chameleons.backend.studies.errors import ConflictError
from chameleons.backend.wizard import robot


@dataclass(frozen=True)
class Slot:
    """Where an interaction runs."""

    study_id: int
    session_id: int
    interaction_id: int
    position: int
    booth: str
    running: bool


def slot_of(db: Session, interaction_id: int) -> Slot | None:
    located = repository.locate(db, interaction_id)
    if located is None:
        return None
    s, i = located.session, located.interaction
    return Slot(s.study_id, s.id, i.id, i.position, s.booth, located.running)


def running_slot(db: Session, booth: str) -> Slot | None:
    """The interaction running on ``booth`` now, if any."""
    session = repository.active_session(db, booth)
    interaction = repository.running_interaction(db, session) if session else None
    return slot_of(db, interaction.id) if interaction is not None else None


def running_target(db: Session, interaction_id: int) -> robot.Target:
    """The robot set-up of this interaction, while it runs (else a conflict: skip it)."""
    located = repository.locate(db, interaction_id)
    if located is None or not located.running:
        raise ConflictError(f"Interaction {interaction_id} is not running.")
    s, i = located.session, located.interaction
    return robot.Target(s.study_id, s.id, i.id, i.position, s.booth, i.condition, i.face)
