"""The lab's other instruments attached to a session (issue 33, docs/instruments.md)."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import ForeignKey, Identity, String, Text, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from chameleons.backend.models.base import NEVER_REUSED_IDS, Base, utcnow


class InstrumentStream(Base):
    """One stream of an XDF recording (EMG, eye tracker, physiology, another tool's
    markers) imported onto a session's timeline by ``chameleons import-xdf``.

    The samples live in a Parquet file under the data dir (``path``, relative to it):
    ``time`` in seconds from the session's start on the server's clock, ``lsl_time`` as
    recorded, then one column per channel (``channels``' labels), or ``value`` for a string
    stream. ``fit`` is how the recording's clock was mapped onto the server's through this
    system's markers (``offset``, ``slope``, ``markers`` matched, ``residual_ms``)."""

    __tablename__ = "instrument_stream"
    __table_args__ = (UniqueConstraint("session_id", "name", "source_id"), NEVER_REUSED_IDS)

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
    session_id: Mapped[int] = mapped_column(
        ForeignKey("session.id", ondelete="CASCADE"), index=True
    )
    name: Mapped[str] = mapped_column(String(256))
    stream_type: Mapped[str] = mapped_column(String(64), default="")
    source_id: Mapped[str] = mapped_column(String(256), default="")
    channel_format: Mapped[str] = mapped_column(String(16))
    nominal_srate: Mapped[float] = mapped_column(default=0.0)
    channels: Mapped[list[Any]] = mapped_column(default=list)
    samples: Mapped[int] = mapped_column(default=0)
    first_s: Mapped[float | None]
    last_s: Mapped[float | None]
    path: Mapped[str] = mapped_column(String(512))
    source_file: Mapped[str] = mapped_column(String(512))
    fit: Mapped[dict[str, Any]] = mapped_column(default=dict)
    imported_at: Mapped[datetime] = mapped_column(default=utcnow)


class CodedAnnotation(Base):
    """One annotation a coder made in ELAN on a session's exported ``.eaf`` and
    ``chameleons import-eaf`` read back (times in ms from the session's start)."""

    __tablename__ = "coded_annotation"
    __table_args__ = (NEVER_REUSED_IDS,)

    id: Mapped[int] = mapped_column(Identity(), primary_key=True)
    session_id: Mapped[int] = mapped_column(
        ForeignKey("session.id", ondelete="CASCADE"), index=True
    )
    coder: Mapped[str] = mapped_column(String(64))
    tier: Mapped[str] = mapped_column(String(128))
    start_ms: Mapped[int]
    end_ms: Mapped[int]
    value: Mapped[str] = mapped_column(Text, default="")
    source_file: Mapped[str] = mapped_column(String(512))
    imported_at: Mapped[datetime] = mapped_column(default=utcnow)
