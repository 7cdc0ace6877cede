from __future__ import annotations

from datetime import datetime

from sqlalchemy import (
    CheckConstraint,
    ForeignKey,
    Identity,
    String,
    Text,
    UniqueConstraint,
    false,
)
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import NEVER_REUSED_IDS, Base, utcnow


class QuestionnaireResponse(Base):
    """One answer to one questionnaire item.

    ``position`` is the interaction's position (1..3) for post-interaction questionnaires
    and 0 for the session-final one, so uniqueness holds without NULLs. ``skipped``: an
    optional item the participant left empty (no value, no text); every other row has an
    answer.
    """

    __tablename__ = "questionnaire_response"
    __table_args__ = (
        UniqueConstraint("session_id", "position", "questionnaire", "item"),
        CheckConstraint("skipped OR value IS NOT NULL OR text IS NOT NULL", name="has_answer"),
        NEVER_REUSED_IDS,
    )

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("session.id", ondelete="CASCADE"))
    interaction_id: Mapped[int | None] = mapped_column(
        ForeignKey("interaction.id", ondelete="CASCADE")
    )
    position: Mapped[int]
    questionnaire: Mapped[str] = mapped_column(String(64))
    version: Mapped[str] = mapped_column(String(64))
    item: Mapped[str] = mapped_column(String(64))
    value: Mapped[int | None]
    text: Mapped[str | None] = mapped_column(Text)
    skipped: Mapped[bool] = mapped_column(default=False, server_default=false())
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
