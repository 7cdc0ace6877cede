from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import Base, utcnow


class Study(Base):
    """A study configuration as it was loaded: the snapshot every data row traces back to."""

    __tablename__ = "study"
    __table_args__ = (UniqueConstraint("name", "config_hash"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(120))
    # Loaded when read: every session read loads its study, and the parsed study is cached
    # by config_hash (studies.specs.spec_of), so decoding the whole document each time
    # was most of the cost of loading a session.
    config: Mapped[dict[str, Any]] = mapped_column(deferred=True)
    config_hash: Mapped[str] = mapped_column(String(64), index=True)
    plan_seed: Mapped[int] = mapped_column(default=0)
    is_active: Mapped[bool] = mapped_column(default=True)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
