from __future__ import annotations

from datetime import datetime

from sqlalchemy import CheckConstraint, ForeignKey, Identity, String
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import NEVER_REUSED_IDS, Base, utcnow


class Recording(Base):
    """A face-stream file a worker wrote for an interaction (indexed, not stored, here).

    ``face_source``/``face_calibration``: for the participant's stream, the capture source
    most of its frames came from (livelink, facecapturex, webcam-browser, webcam-python) and
    a webcam's calibration (geometric, neutral, iphone:<hash>...; None for an iPhone)."""

    __tablename__ = "recording"
    __table_args__ = (
        CheckConstraint("stream IN ('participant', 'agent')", name="stream"),
        NEVER_REUSED_IDS,
    )

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
    interaction_id: Mapped[int] = mapped_column(ForeignKey("interaction.id", ondelete="CASCADE"))
    stream: Mapped[str] = mapped_column(String(16))
    path: Mapped[str] = mapped_column(String(512))
    frames: Mapped[int] = mapped_column(default=0)
    size_bytes: Mapped[int] = mapped_column(default=0)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    face_source: Mapped[str | None] = mapped_column(String(32))
    face_calibration: Mapped[str | None] = mapped_column(String(64))
