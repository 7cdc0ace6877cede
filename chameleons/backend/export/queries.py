"""Queries shared by the export tables, the scores and the dashboard."""

from __future__ import annotations

from typing import Any

from sqlalchemy import ColumnElement, Select, false, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import Interaction, Participant, Session, Suggestion

BATCH = 1000


def session_filter(study_id: int, include_rehearsal: bool) -> list[ColumnElement[bool]]:
    """WHERE clauses for a query joined to Session and Participant."""
    clauses: list[ColumnElement[bool]] = [Session.study_id == study_id]
    if not include_rehearsal:
        clauses += [Session.is_rehearsal == false(), Participant.is_rehearsal == false()]
    return clauses


def joined(query: Select[Any], study_id: int, include_rehearsal: bool) -> Select[Any]:
    return query.join(Participant, Participant.id == Session.participant_id).where(
        *session_filter(study_id, include_rehearsal)
    )


def accepted_counts(db: DbSession, interaction_ids: list[int]) -> dict[int, int]:
    counts = dict.fromkeys(interaction_ids, 0)
    if not interaction_ids:
        return counts
    query = select(Suggestion.interaction_id, Suggestion.accepted).where(
        Suggestion.interaction_id.in_(interaction_ids)
    )
    for interaction_id, accepted in db.execute(query):
        if accepted:
            counts[interaction_id] += 1
    return counts


def counted_interactions(
    db: DbSession, study_id: int, include_rehearsal: bool
) -> list[tuple[Interaction, str]]:
    """The counted interactions with their participant codes, in code/session/position order."""
    query = select(Interaction, Participant.code).join(
        Session, Session.id == Interaction.session_id
    )
    query = joined(query, study_id, include_rehearsal).order_by(
        Participant.code, Session.id, Interaction.position
    )
    return [(interaction, code) for interaction, code in db.execute(query).tuples()]
