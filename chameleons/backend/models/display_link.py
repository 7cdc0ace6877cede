from __future__ import annotations

from datetime import datetime

from sqlalchemy import String
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import Base, utcnow


class DisplayLink(Base):
    """A booth's robot-display link: its generation (the PI rotates it) and retirement.

    A booth without a row has generation 0 (the link derived from the secret key alone);
    rotating bumps ``generation`` and every older link stops working; ``retired_at`` set
    means no link of the booth works until the PI issues a new one. ``renderer`` (2d|3d)
    and ``head`` (a file in the heads folder) are the booth's display defaults; None: the
    server's setting and the built-in head."""

    __tablename__ = "display_link"

    booth: Mapped[str] = mapped_column(String(64), primary_key=True)
    generation: Mapped[int] = mapped_column(default=0)
    retired_at: Mapped[datetime | None]
    updated_at: Mapped[datetime] = mapped_column(default=utcnow)
    renderer: Mapped[str | None] = mapped_column(String(8))
    head: Mapped[str | None] = mapped_column(String(128))
