from __future__ import annotations

from datetime import datetime

from sqlalchemy import CheckConstraint, ForeignKey, Identity, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import NEVER_REUSED_IDS, Base, utcnow


class Suggestion(Base):
    """One of the robot's ranking change requests in an interaction (the study says how
    many); it moves an item up or, under the best-move rule, down."""

    __tablename__ = "suggestion"
    __table_args__ = (
        UniqueConstraint("interaction_id", "index"),
        CheckConstraint('"index" >= 1', name="index_range"),
        CheckConstraint("kind IN ('optimal', 'random')", name="kind"),
        CheckConstraint("to_rank <> from_rank AND to_rank >= 1", name="moves"),
        NEVER_REUSED_IDS,
    )

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
    interaction_id: Mapped[int] = mapped_column(ForeignKey("interaction.id", ondelete="CASCADE"))
    index: Mapped[int]
    item: Mapped[str] = mapped_column(String(64))
    from_rank: Mapped[int]
    to_rank: Mapped[int]
    kind: Mapped[str] = mapped_column(String(16))
    accepted: Mapped[bool | None]
    proposed_at: Mapped[datetime] = mapped_column(default=utcnow)
    decided_at: Mapped[datetime | None]
