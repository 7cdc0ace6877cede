from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import ForeignKey, Identity, String
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import NEVER_REUSED_IDS, Base, utcnow


class InteractionSynchrony(Base):
    """The synchrony of an interaction's recorded faces (issue 32), computed in the
    background when its recording stops and again by ``chameleons synchrony``; one row per
    interaction, replaced on recomputing.

    ``reason``/``detail`` say why the values are empty (no recording, too short, a still
    robot, ...). ``params`` is how it was computed, ``surrogates`` which pseudo-pairs (each
    ``[participant recording ids, robot recording ids]``) made the baseline, ``recordings``
    the recording ids measured, ``curves`` the lag curves the session page plots."""

    __tablename__ = "interaction_synchrony"
    __table_args__ = (NEVER_REUSED_IDS,)

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
    interaction_id: Mapped[int] = mapped_column(
        ForeignKey("interaction.id", ondelete="CASCADE"), unique=True
    )
    computed_at: Mapped[datetime] = mapped_column(default=utcnow)
    reason: Mapped[str | None] = mapped_column(String(32))
    detail: Mapped[str] = mapped_column(String(512), default="")
    sync_lag_s: Mapped[float | None]
    sync_r: Mapped[float | None]
    sync_band_r: Mapped[float | None]
    sync_p: Mapped[float | None]
    mimicry_lag_s: Mapped[float | None]
    mimicry_r: Mapped[float | None]
    mimicry_raw_r: Mapped[float | None]
    mimicry_surrogate_r: Mapped[float | None]
    mimicry_p: Mapped[float | None]
    check: Mapped[str | None] = mapped_column(String(16))
    check_reason: Mapped[str] = mapped_column(String(512), default="")
    usable_share: Mapped[float | None]
    face_source: Mapped[str | None] = mapped_column(String(32))
    surrogate_kind: Mapped[str] = mapped_column(String(16), default="none")
    surrogate_count: Mapped[int] = mapped_column(default=0)
    params: Mapped[dict[str, Any]] = mapped_column(default=dict)
    surrogates: Mapped[list[Any]] = mapped_column(default=list)
    recordings: Mapped[list[Any]] = mapped_column(default=list)
    channels: Mapped[list[Any]] = mapped_column(default=list)
    curves: Mapped[dict[str, Any]] = mapped_column(default=dict)
