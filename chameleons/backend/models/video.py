"""The participant's video (issue 33): the booth's camera recorded in the browser with
``MediaRecorder``, uploaded chunk by chunk (docs/instruments.md, *Participant video*)."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import ForeignKey, Identity, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import NEVER_REUSED_IDS, Base, utcnow


class ParticipantVideo(Base):
    """One recording of the booth's camera during a session (a page reloaded mid-session
    starts another). The chunks are appended, in order, to one WebM file under the data dir
    (``path``, relative to it). ``started_at`` is the server's time of the video's first
    frame (media time 0), mapped from the page's clock (``clock``: the page's
    ``performance.now()`` at the recorder's start, the page-to-server offset and the round
    trip it was measured over). ``refused`` counts the chunks that were not stored
    (malformed, out of order, duplicate, too large)."""

    __tablename__ = "participant_video"
    __table_args__ = (NEVER_REUSED_IDS,)

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
    session_id: Mapped[int] = mapped_column(
        ForeignKey("session.id", ondelete="CASCADE"), index=True
    )
    booth: Mapped[str] = mapped_column(String(64))
    mime_type: Mapped[str] = mapped_column(String(128))
    audio: Mapped[bool] = mapped_column(default=False)
    path: Mapped[str] = mapped_column(String(512))
    started_at: Mapped[datetime]
    clock: Mapped[dict[str, Any]] = mapped_column(default=dict)
    chunks: Mapped[int] = mapped_column(default=0)
    size_bytes: Mapped[int] = mapped_column(default=0)
    refused: Mapped[int] = mapped_column(default=0)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    last_chunk_at: Mapped[datetime | None]
    stopped_at: Mapped[datetime | None]


class VideoChunk(Base):
    """One ``MediaRecorder`` timeslice as stored: where it sits in the video's file
    (``offset``, ``size``), the page's media time at its end (``media_ms``), when it came."""

    __tablename__ = "participant_video_chunk"
    __table_args__ = (UniqueConstraint("video_id", "seq"), NEVER_REUSED_IDS)

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
    video_id: Mapped[int] = mapped_column(
        ForeignKey("participant_video.id", ondelete="CASCADE"), index=True
    )
    seq: Mapped[int]
    offset: Mapped[int]
    size: Mapped[int]
    media_ms: Mapped[float | None]
    received_at: Mapped[datetime] = mapped_column(default=utcnow)
