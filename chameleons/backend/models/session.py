from __future__ import annotations

from datetime import datetime

from sqlalchemy import ForeignKey, Identity, String, Text
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import NEVER_REUSED_IDS, Base, utcnow


class Session(Base):
    """A participant's run through their plan row; its phone link opens only this session.

    ``state`` is pending -> running -> final_questionnaire -> complete, or ``ended`` when the
    wizard ended it early (``end_reason``: participant_withdrew, technical_failure, time,
    other; ``end_note`` says more) or the participant declined consent on the phone
    (``consent_declined``). An ended session keeps all its data. ``consent_at``: when the
    participant agreed on the phone (studies with a consent page).

    A running session (or one in its final questionnaire) may be paused: ``paused_at`` is
    set while it is (``pause_reason``, ``pause_note`` say why); nothing moves on meanwhile.
    ``pause_count`` and ``paused_seconds`` add up the pauses that have ended (a pause still
    open when the session ends is closed then)."""

    __tablename__ = "session"
    __table_args__ = NEVER_REUSED_IDS

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
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
    # The participant's language (a code the study declares): phone pages, study texts,
    # prompts. Chosen at registration or on the phone's first page, before consent.
    language: Mapped[str] = mapped_column(String(16), default="en", server_default="en")
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    consent_at: Mapped[datetime | None]
    started_at: Mapped[datetime | None]
    completed_at: Mapped[datetime | None]
    ended_at: Mapped[datetime | None]
    end_reason: Mapped[str | None] = mapped_column(String(32))
    end_note: Mapped[str | None] = mapped_column(Text)
    paused_at: Mapped[datetime | None]
    pause_reason: Mapped[str | None] = mapped_column(String(32))
    pause_note: Mapped[str | None] = mapped_column(Text)
    pause_count: Mapped[int] = mapped_column(default=0, server_default="0")
    paused_seconds: Mapped[float] = mapped_column(default=0.0, server_default="0")
    # The consent step's video items (a study with ``procedure.video``): whether the
    # participant agreed to be filmed, and to their voice being recorded with it.
    video_consent: Mapped[bool | None]
    video_audio_consent: Mapped[bool | None]
