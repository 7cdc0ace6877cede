"""Declarative base with a naming convention, so Alembic names constraints predictably."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from sqlalchemy import JSON, DateTime, MetaData
from sqlalchemy.orm import DeclarativeBase

NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}


def utcnow() -> datetime:
    return datetime.now(UTC)


class Base(DeclarativeBase):
    metadata = MetaData(naming_convention=NAMING_CONVENTION)
    type_annotation_map = {
        datetime: DateTime(timezone=True),
        dict[str, Any]: JSON,
        list[Any]: JSON,
    }


# Ids of participant data are never handed out twice, even after a withdrawal deleted the
# highest ones: a console tab, a file name (``interaction-<id>-...``) or an event cursor
# that names a deleted id must never come to mean someone else. SQLite reuses the largest
# rowid unless the table says AUTOINCREMENT; PostgreSQL identity columns (like the sequences
# of SERIAL before them) never go back.
NEVER_REUSED_IDS = {"sqlite_autoincrement": True}
