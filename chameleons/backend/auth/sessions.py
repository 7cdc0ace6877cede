"""Server-side staff sessions: what the login cookie points to, and ending them.

The signed cookie holds a random key (``SESSION_KEY``); the database holds its SHA-256 with
the user, an expiry (``CHAMELEONS_STAFF_SESSION_HOURS``) and, once ended, why. A cookie is
good only while its record is open, unexpired and its user active, so logout, "log out
everywhere" and deactivation take effect at once (OWASP Session Management Cheat Sheet:
server-side invalidation on logout), for WebSockets already open too: ending a session
announces it after the commit and its sockets are closed (:mod:`.socket_revocation`).
Flushes only; the caller commits.
"""

from __future__ import annotations

import hashlib
import secrets
from collections.abc import Mapping
from datetime import UTC, datetime, timedelta
from typing import Any

from sqlalchemy import bindparam, func, select, update
from sqlalchemy.orm import Session

from chameleons.backend.auth.socket_revocation import announce_ended
from chameleons.backend.models import StaffSession, StaffUser
from chameleons.backend.models.base import utcnow

SESSION_KEY = "staff_session"


def _hash(key: str) -> str:
    return hashlib.sha256(key.encode()).hexdigest()


def _aware(moment: datetime) -> datetime:
    return moment if moment.tzinfo else moment.replace(tzinfo=UTC)  # SQLite drops the zone


def start(db: Session, user: StaffUser, hours: float) -> str:
    """A new session for ``user``; returns the key for the cookie."""
    key = secrets.token_urlsafe(32)
    now = utcnow()
    db.add(
        StaffSession(
            key_hash=_hash(key),
            user_id=user.id,
            created_at=now,
            expires_at=now + timedelta(hours=hours),
        )
    )
    db.flush()
    return key


# One statement, built once (every staff request and socket asks): the session with its user.
SIGNED_IN = (
    select(StaffSession, StaffUser)
    .join(StaffUser, StaffUser.id == StaffSession.user_id)
    .where(StaffSession.key_hash == bindparam("key_hash"))
)


def _key_hash(cookie: Mapping[str, Any]) -> str | None:
    key = cookie.get(SESSION_KEY)
    return _hash(key) if isinstance(key, str) and key else None


def _record(db: Session, cookie: Mapping[str, Any]) -> StaffSession | None:
    key_hash = _key_hash(cookie)
    if key_hash is None:
        return None
    return db.scalars(select(StaffSession).where(StaffSession.key_hash == key_hash)).first()


def signed_in(db: Session, cookie: Mapping[str, Any]) -> tuple[StaffUser, int] | None:
    """The active staff member whose open, unexpired session the cookie names, with that
    session's id (a WebSocket watches it: see :mod:`.socket_revocation`)."""
    key_hash = _key_hash(cookie)
    if key_hash is None:
        return None
    found = db.execute(SIGNED_IN, {"key_hash": key_hash}).first()
    if found is None:
        return None
    record, user = found._tuple()
    if record.ended_at is not None or _aware(record.expires_at) <= datetime.now(UTC):
        return None
    return (user, record.id) if user.is_active else None


def staff_of(db: Session, cookie: Mapping[str, Any]) -> StaffUser | None:
    """The active staff member whose open, unexpired session the cookie names."""
    found = signed_in(db, cookie)
    return found[0] if found is not None else None


def end(db: Session, cookie: Mapping[str, Any], reason: str = "logout") -> None:
    record = _record(db, cookie)
    if record is not None and record.ended_at is None:
        record.ended_at = utcnow()
        record.end_reason = reason
        db.flush()
        announce_ended(db, [record.id], reason)


def end_all(db: Session, user_id: int, reason: str) -> int:
    """End every open session of the user (log out everywhere, deactivation)."""
    ids = list(
        db.scalars(
            select(StaffSession.id).where(
                StaffSession.user_id == user_id, StaffSession.ended_at.is_(None)
            )
        )
    )
    if ids:
        db.execute(
            update(StaffSession)
            .where(StaffSession.id.in_(ids), StaffSession.ended_at.is_(None))
            .values(ended_at=utcnow(), end_reason=reason)
        )
        db.flush()
        announce_ended(db, ids, reason)
    return len(ids)


def open_counts(db: Session) -> dict[int, int]:
    """Open (unended, unexpired) sessions per user id."""
    rows = db.execute(
        select(StaffSession.user_id, func.count())
        .where(StaffSession.ended_at.is_(None), StaffSession.expires_at > utcnow())
        .group_by(StaffSession.user_id)
    )
    return {int(user_id): int(count) for user_id, count in rows}
