"""The console's *Participant video* chip: whether the booth's recording page
(``/video/<booth>/<key>``, docs/instruments.md "Participant video") films a session whose
study records video and whose participant agreed.

Green while chunks come (the page uploads one every 2 s), amber once a running session has
had none for :data:`SILENT_AFTER_S` (the page is closed, has no camera, or was never
opened), grey when nobody is to be filmed now; no chip for a study that films nobody.
Health is sent only when it changes: the value says the coarse state and the chunk count,
and the seconds since the last chunk go apart (``since_s``), which the console counts on
from the message's arrival, as it does a failing check's time.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime

from sqlalchemy import func, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import ParticipantVideo, Session, Study
from chameleons.backend.studies.specs import spec_of
from chameleons.backend.wizard.health_checks import Check

SILENT_AFTER_S = 6.0  # three missed 2 s chunks
CHIP = "video"
NOT_OPEN = "video consented but the booth's recording page is not open/recording"


@dataclass(frozen=True)
class Filming:
    """What the chip needs of a session: its state and consent, and the chunks stored of
    all its videos (``last_chunk_at``: when the newest came; None: none). Read here, not
    through the video feature, which sits above the wizard's (its pages link the capture's)."""

    state: str
    consent: bool | None
    started_at: datetime | None
    chunks: int
    last_chunk_at: datetime | None


def study_records_video(db: DbSession, study_id: int | None) -> bool:
    """Whether the study films consenting participants (``procedure.video.record``)."""
    study = db.get(Study, study_id) if study_id is not None else None
    return study is not None and spec_of(study).procedure.records_video


def filming(db: DbSession, session_id: int) -> Filming | None:
    """The session's filming now (None: no such session). Two small reads, by key."""
    session = db.get(Session, session_id)
    if session is None:
        return None
    totals = select(func.coalesce(func.sum(ParticipantVideo.chunks), 0),
                    func.max(ParticipantVideo.last_chunk_at)
                    ).where(ParticipantVideo.session_id == session_id)  # fmt: skip
    chunks, last = db.execute(totals).one()
    return Filming(state=session.state, consent=session.video_consent,
                   started_at=_utc(session.started_at), chunks=int(chunks),
                   last_chunk_at=_utc(last))  # fmt: skip


def _utc(moment: datetime | None) -> datetime | None:
    """SQLite gives the stored moments back without their zone (they are UTC)."""
    if moment is None or moment.tzinfo is not None:
        return moment
    return moment.replace(tzinfo=UTC)


def video_check(filming: Filming | None, now: datetime) -> dict[str, Check]:
    """The chip for the session's filming at ``now`` (None: no session, no chip)."""
    if filming is None:
        return {}
    if not filming.consent:
        value = ("waiting for the participant's consent" if filming.state == "pending"
                 and filming.consent is None else "not filmed: no consent")  # fmt: skip
        return {CHIP: Check(CHIP, None, value)}
    since = None if filming.last_chunk_at is None else max(
        0.0, (now - filming.last_chunk_at).total_seconds())  # fmt: skip
    if filming.state != "running":
        if filming.state == "pending":
            return {CHIP: Check(CHIP, None, "consented: filmed once the session runs")}
        return {CHIP: Check(CHIP, None, f"not filming now: {_chunks(filming.chunks)} recorded")}
    if since is not None and since < SILENT_AFTER_S:
        return {CHIP: Check(CHIP, True, f"recording: {_chunks(filming.chunks)}",
                            since_s=since)}  # fmt: skip
    started = filming.started_at
    if since is None and started is not None and (now - started).total_seconds() < SILENT_AFTER_S:
        return {CHIP: Check(CHIP, None, "starting: waiting for the recording page's first chunk")}
    if since is None:
        return {CHIP: Check(CHIP, False, f"{NOT_OPEN}: no chunk yet")}
    return {CHIP: Check(CHIP, False, f"{NOT_OPEN}: {_chunks(filming.chunks)}", since_s=since)}


def _chunks(count: int) -> str:
    return "1 chunk" if count == 1 else f"{count} chunks"
