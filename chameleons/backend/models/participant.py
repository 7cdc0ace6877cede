from __future__ import annotations

from datetime import datetime

from sqlalchemy import CheckConstraint, ForeignKey, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import Base, utcnow

PARTICIPANT_STATUSES = ("registered", "active", "complete")


class Participant(Base):
    """A pseudonymous participant (no names). Withdrawal deletes the row and all it owns."""

    __tablename__ = "participant"
    __table_args__ = (
        UniqueConstraint("study_id", "code"),
        # One participant per plan row at a time; a withdrawn participant's row is freed.
        UniqueConstraint("plan_row_id"),
        CheckConstraint("status IN ('registered', 'active', 'complete')", name="status"),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    study_id: Mapped[int] = mapped_column(ForeignKey("study.id", ondelete="RESTRICT"))
    code: Mapped[str] = mapped_column(String(32))
    plan_row_id: Mapped[int | None] = mapped_column(ForeignKey("plan_row.id", ondelete="RESTRICT"))
    status: Mapped[str] = mapped_column(String(16), default="registered")
    is_rehearsal: Mapped[bool] = mapped_column(default=False)
    consent_at: Mapped[datetime | None]
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
