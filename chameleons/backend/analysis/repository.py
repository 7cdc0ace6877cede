"""The data version an analysis is cached under: cheap to read, and changed by every change
of the rows an analysis reads.

Every change of a session's data (a ranking, a decision, an answer, an exclusion, a
condition switch, a withdrawal) logs an event in the same transaction, so the newest event
id and the number of events move with it; the newest ids of the tables new rows arrive in
cover rows written without an event (a test's factories, an import). Each part is read
from a primary key or an index (no row of the study is read), so a repeated visit of the
analysis page costs a few milliseconds instead of reading every row (docs/performance.md).
"""

from __future__ import annotations

from sqlalchemy import func, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import (
    Event,
    Interaction,
    Participant,
    QuestionnaireResponse,
    Suggestion,
)
from chameleons.backend.models import Session as SessionRow

DataVersion = tuple[int, ...]
TABLES = (Event, Participant, SessionRow, Interaction, Suggestion, QuestionnaireResponse)


def data_version(db: DbSession) -> DataVersion:
    newest = [select(func.max(model.id)).scalar_subquery() for model in TABLES]
    events = select(func.count(Event.id)).scalar_subquery()
    found = db.execute(select(events, *newest)).one()
    return tuple(int(value or 0) for value in found)
