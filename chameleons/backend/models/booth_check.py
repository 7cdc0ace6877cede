from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import JSON, BigInteger, ForeignKey, Identity, String
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import NEVER_REUSED_IDS, Base, utcnow


class BoothCheck(Base):
    """One run of the booth check (``/booths/<booth>/check``, ``chameleons booth-check``),
    with the session it was run for when one was given: pass/fail per step in ``steps``
    and the figures a lab compares across sessions as columns (exported)."""

    __tablename__ = "booth_check"
    __table_args__ = (NEVER_REUSED_IDS,)

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
    booth: Mapped[str] = mapped_column(String(64))
    study_id: Mapped[int | None] = mapped_column(ForeignKey("study.id", ondelete="CASCADE"))
    session_id: Mapped[int | None] = mapped_column(
        ForeignKey("session.id", ondelete="CASCADE"), index=True
    )
    checked_at: Mapped[datetime] = mapped_column(default=utcnow)
    passed: Mapped[bool]
    steps: Mapped[list[dict[str, Any]]] = mapped_column(JSON, default=list)
    face_fps: Mapped[float | None]
    capture_to_send_ms: Mapped[float | None]
    head_yaw_deg: Mapped[float | None]
    head_pitch_deg: Mapped[float | None]
    copy_delay_s: Mapped[float | None]  # configured
    measured_delay_s: Mapped[float | None]  # head movement to the robot's copy of it
    speech_start_ms: Mapped[float | None]  # command to the robot's speech start
    speech_ok: Mapped[bool | None]
    disk_free_bytes: Mapped[int | None] = mapped_column(BigInteger)
