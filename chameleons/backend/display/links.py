"""Booth display links the PI can rotate (old links stop at once) and retire.

A link is ``HMAC(secret_key, "display:<booth>")`` at generation 0 (a booth without a
``display_link`` row) and ``HMAC(secret_key, "display:<booth>#<generation>")`` after
rotations; a retired booth has no valid link until the PI rotates it again.
"""

from __future__ import annotations

from fastapi import FastAPI
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.db import session_scope
from chameleons.backend.display.tokens import (
    check_token,
    display_path,
    display_token,
    signing_key,
)
from chameleons.backend.models import DisplayLink
from chameleons.backend.models.base import utcnow


def generation(db: DbSession, booth: str) -> int | None:
    """The booth's current link generation; ``None`` when the booth is retired."""
    row = db.get(DisplayLink, booth)
    if row is None:
        return 0
    return None if row.retired_at is not None else row.generation


def retired_booths(db: DbSession) -> set[str]:
    rows = db.scalars(select(DisplayLink.booth).where(DisplayLink.retired_at.is_not(None)))
    return set(rows)


def _row(db: DbSession, booth: str) -> DisplayLink:
    row = db.get(DisplayLink, booth)
    if row is None:
        row = DisplayLink(booth=booth, generation=0)
        db.add(row)
    return row


def rotate(db: DbSession, booth: str) -> int:
    """A new link for the booth (also brings a retired booth back); returns its generation."""
    row = _row(db, booth)
    row.generation += 1
    row.retired_at = None
    row.updated_at = utcnow()
    db.flush()
    return row.generation


def retire(db: DbSession, booth: str) -> None:
    row = _row(db, booth)
    row.retired_at = utcnow()
    row.updated_at = utcnow()
    db.flush()


def defaults(db: DbSession, booth: str) -> tuple[str | None, str | None]:
    """The booth's display defaults: (renderer, head file), None where not set."""
    row = db.get(DisplayLink, booth)
    return (None, None) if row is None else (row.renderer, row.head)


def set_defaults(db: DbSession, booth: str, renderer: str | None, head: str | None) -> None:
    row = _row(db, booth)
    row.renderer = renderer
    row.head = head
    row.updated_at = utcnow()
    db.flush()


def current_path(app: FastAPI, booth: str) -> str | None:
    """The booth's working display path, read from the app's database; ``None`` if retired."""
    with session_scope(app.state.sessionmaker) as db:
        current = generation(db, booth)
    return None if current is None else display_path(signing_key(app), booth, current)


def token_works(db: DbSession, app: FastAPI, booth: str, token: str | None) -> bool:
    current = generation(db, booth)
    return current is not None and check_token(
        display_token(signing_key(app), booth, current), token
    )
