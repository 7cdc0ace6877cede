"""The video feature's reads: the session running at a booth."""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import Session


def active_session(db: DbSession, booth: str) -> Session | None:
    """The session running at ``booth`` (the most recently started, should there be more;
    as the booth's robot follows it, ``booth.repository.active_session``)."""
    query = (select(Session)
             .where(Session.booth == booth, Session.state == "running")
             .order_by(Session.started_at.desc(), Session.id.desc())
             .limit(1))  # fmt: skip
    return db.scalars(query).first()
