from __future__ import annotations

from datetime import datetime

from sqlalchemy import CheckConstraint, ForeignKey, Identity, String, Text, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import NEVER_REUSED_IDS, Base, utcnow

PARTICIPANT_STATUSES = ("registered", "active", "complete", "ended_early")


class Participant(Base):
    """A pseudonymous participant (no names). Withdrawal deletes the row and all it owns.

    ``excluded_at``/``exclusion_reason``: the PI left the participant out of the analysis
    without deleting anything. ``plan_row_id`` is None for a rehearsal, and for a dropout
    whose row was handed to a replacement (their session still names the row)."""

    __tablename__ = "participant"
    __table_args__ = (
        UniqueConstraint("study_id", "code"),
        # One participant per plan row at a time; a withdrawn participant's row is freed.
        UniqueConstraint("plan_row_id"),
        CheckConstraint(
            "status IN ('registered', 'active', 'complete', 'ended_early', 'declined')",
            name="status",
        ),
        NEVER_REUSED_IDS,
    )

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
    study_id: Mapped[int] = mapped_column(ForeignKey("study.id", ondelete="RESTRICT"))
    code: Mapped[str] = mapped_column(String(32))
    plan_row_id: Mapped[int | None] = mapped_column(ForeignKey("plan_row.id", ondelete="RESTRICT"))
    status: Mapped[str] = mapped_column(String(16), default="registered")
    is_rehearsal: Mapped[bool] = mapped_column(default=False)
    consent_at: Mapped[datetime | None]
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    excluded_at: Mapped[datetime | None]
    exclusion_reason: Mapped[str | None] = mapped_column(Text)
