"""Reads the console needs: a session with its study, participant and interactions, and the
prompt events of the timeline. Read-only except through :mod:`events.repository`."""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy import select
from sqlalchemy.orm import Session

from chameleons.backend.models import Event, Interaction, Participant
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.models import Study as StudyRow
from chameleons.backend.sessions.flow import load as load_flow
from chameleons.backend.studies.errors import NotFoundError
from chameleons.backend.studies.specs import item_key
from chameleons.experiment.model import Study

PLAYED = "prompt.played"
RECENT_PLAYS = 2000


class SessionNotFoundError(LookupError):
    pass


@dataclass
class SessionView:
    session: SessionRow
    study: StudyRow
    spec: Study
    participant: Participant
    interactions: list[Interaction]

    def at(self, position: int) -> Interaction | None:
        for interaction in self.interactions:
            if interaction.position == position:
                return interaction
        return None

    @property
    def current(self) -> Interaction | None:
        """The interaction running now, or the next one once the current one is done (its
        prompts are the ones the wizard needs next), as the session flow counts it."""
        current = self.at(self.session.current_position)
        if current is not None and current.state == "done":
            return self.at(current.position + 1) or current
        return current

    def item_names(self, interaction: Interaction) -> dict[str, str]:
        task = self.spec.task(interaction.task)
        return {item: task.item(item_key(item)).name for item in interaction.presented_order or []}


def load_session(db: Session, session_id: int) -> SessionView:
    """The session as the session flow loads it (without its write lock)."""
    try:
        flow = load_flow(db, session_id, lock=False)
    except NotFoundError as exc:
        raise SessionNotFoundError(exc.message) from None
    return SessionView(flow.session, flow.study, flow.spec, flow.participant, flow.interactions)


def last_played_variant(db: Session, session_id: int, group: str) -> str | None:
    """The prompt id last played from ``group`` in this session (variants do not repeat)."""
    query = (
        select(Event)
        .where(Event.session_id == session_id, Event.kind == PLAYED)
        .order_by(Event.id.desc())
        .limit(RECENT_PLAYS)
    )
    for event in db.scalars(query):
        if event.payload.get("group") == group:
            prompt_id = event.payload.get("prompt_id")
            return prompt_id if isinstance(prompt_id, str) else None
    return None


def played_event(db: Session, session_id: int, event_id: int) -> Event | None:
    event = db.get(Event, event_id)
    if event is None or event.session_id != session_id or event.kind != PLAYED:
        return None
    return event


def last_played(db: Session, session_id: int) -> Event | None:
    query = (
        select(Event)
        .where(Event.session_id == session_id, Event.kind == PLAYED)
        .order_by(Event.id.desc())
        .limit(1)
    )
    return db.scalars(query).first()


def recent_sessions(db: Session, limit: int = 30) -> list[tuple[SessionRow, Participant]]:
    query = (
        select(SessionRow, Participant)
        .join(Participant, Participant.id == SessionRow.participant_id)
        .order_by(SessionRow.id.desc())
        .limit(limit)
    )
    return [(row, person) for row, person in db.execute(query).tuples()]
