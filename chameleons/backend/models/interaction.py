from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import CheckConstraint, ForeignKey, Identity, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import NEVER_REUSED_IDS, Base


class Interaction(Base):
    """One of a session's interactions (one per condition), as planned and as actually run.

    ``natural_source``/``natural_recording``: what the ``natural`` behaviour replayed in this
    interaction (clip, yoked or synthetic, and which recording), set when it first ran.
    ``renderer``: the face the virtual robot's display was told to paint (2d|3d) when the
    study's condition chose one; None where the booth's default applied.
    ``face_source``/``face_calibration``: what captured the participant, from the
    participant's recording (see :class:`Recording`); None until one is indexed.
    ``behaviour_params``/``behaviour_words``: the parameters the worker was sent for the
    interaction's behaviour (with the seed the server chose) and the same in words
    (``copies head, 4 s late, mirror image``), set when the robot is set up."""

    __tablename__ = "interaction"
    __table_args__ = (
        UniqueConstraint("session_id", "position"),
        CheckConstraint("position >= 1", name="position"),
        NEVER_REUSED_IDS,
    )

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("session.id", ondelete="CASCADE"))
    position: Mapped[int]
    state: Mapped[str] = mapped_column(String(32), default="pending")
    planned_condition: Mapped[str] = mapped_column(String(32))
    condition: Mapped[str] = mapped_column(String(32))
    actor: Mapped[str] = mapped_column(String(64))
    robot_name: Mapped[str] = mapped_column(String(64))
    face: Mapped[str] = mapped_column(String(64))
    task: Mapped[str] = mapped_column(String(64))
    item_set: Mapped[str] = mapped_column(String(32))
    presented_order: Mapped[list[Any]]
    initial_ranking: Mapped[list[Any] | None]
    current_ranking: Mapped[list[Any] | None]
    final_ranking: Mapped[list[Any] | None]
    natural_source: Mapped[str | None] = mapped_column(String(16))
    natural_recording: Mapped[str | None] = mapped_column(String(255))
    renderer: Mapped[str | None] = mapped_column(String(8))
    face_source: Mapped[str | None] = mapped_column(String(32))
    face_calibration: Mapped[str | None] = mapped_column(String(64))
    behaviour_params: Mapped[dict[str, Any] | None]
    behaviour_words: Mapped[str | None] = mapped_column(String(512))
    started_at: Mapped[datetime | None]
    ended_at: Mapped[datetime | None]
