from __future__ import annotations

from datetime import datetime

from sqlalchemy import ForeignKey, String
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import Base, utcnow


class Session(Base):
    """A participant's run through their plan row; its phone link opens only this session."""

    __tablename__ = "session"

    id: Mapped[int] = mapped_column(primary_key=True)
    study_id: Mapped[int] = mapped_column(ForeignKey("study.id", ondelete="RESTRICT"))
    participant_id: Mapped[int] = mapped_column(
        ForeignKey("participant.id", ondelete="CASCADE"), index=True
    )
    plan_row_id: Mapped[int] = mapped_column(ForeignKey("plan_row.id", ondelete="RESTRICT"))
    booth: Mapped[str] = mapped_column(String(64), default="booth-1")
    state: Mapped[str] = mapped_column(String(32), default="pending")
    current_position: Mapped[int] = mapped_column(default=1)
    phone_token: Mapped[str] = mapped_column(String(64), unique=True)
    short_code: Mapped[str] = mapped_column(String(16), unique=True)
    is_rehearsal: Mapped[bool] = mapped_column(default=False)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    started_at: Mapped[datetime | None]
    completed_at: Mapped[datetime | None]
