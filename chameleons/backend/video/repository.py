"""The video feature's reads: the session running at a booth, a session's filming."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime

from sqlalchemy import func, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import ParticipantVideo, Session


def active_session(db: DbSession, booth: str) -> Session | None:
    """The session running at ``booth`` (the most recently started, should there be more;
    as the booth's robot follows it, ``booth.repository.active_session``)."""
    query = (select(Session)
             .where(Session.booth == booth, Session.state == "running")
             .order_by(Session.started_at.desc(), Session.id.desc())
             .limit(1))  # fmt: skip
    return db.scalars(query).first()


@dataclass(frozen=True)
class Filming:
    """What the console's video chip needs of a session: its state and consent, and the
    chunks stored of all its videos (``last_chunk_at``: when the newest came; None: none)."""

    state: str
    consent: bool | None
    started_at: datetime | None
    chunks: int
    last_chunk_at: datetime | None


def filming(db: DbSession, session_id: int) -> Filming | None:
    """The session's filming now (None: no such session). Two small reads, by key."""
    session = db.get(Session, session_id)
    if session is None:
        return None
    totals = select(func.coalesce(func.sum(ParticipantVideo.chunks), 0),
                    func.max(ParticipantVideo.last_chunk_at)
                    ).where(ParticipantVideo.session_id == session_id)  # fmt: skip
    chunks, last = db.execute(totals).one()
    return Filming(state=session.state, consent=session.video_consent,
                   started_at=_utc(session.started_at), chunks=int(chunks),
                   last_chunk_at=_utc(last))  # fmt: skip


def _utc(moment: datetime | None) -> datetime | None:
    """SQLite gives the stored moments back without their zone (they are UTC)."""
    if moment is None or moment.tzinfo is not None:
        return moment
    return moment.replace(tzinfo=UTC)
