from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import ForeignKey, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import Base, utcnow


class PlanRow(Base):
    """One participant slot of the counterbalancing plan (three planned interactions).

    A withdrawn participant's row is freed for a replacement; ``withdrawals`` counts how
    often that happened, ``dropouts`` how often the row was handed on from a participant
    whose data were kept (ended early, excluded, never started), so progress can report
    used / free / withdrawn / dropped out / replaced.
    """

    __tablename__ = "plan_row"
    __table_args__ = (UniqueConstraint("study_id", "row_number"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    study_id: Mapped[int] = mapped_column(ForeignKey("study.id", ondelete="CASCADE"))
    row_number: Mapped[int]
    interactions: Mapped[list[Any]]
    withdrawals: Mapped[int] = mapped_column(default=0)
    dropouts: Mapped[int] = mapped_column(default=0, server_default="0")
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
