"""Who is filmed, and the chunks stored in order.

A booth's camera is recorded while a session runs at the booth (wizard's start to the
session's end, pauses included) whose study records video (``procedure.video``) and whose
participant ticked the video item on the consent page; the microphone only with the audio
item ticked too. Chunks are stored in sequence only: a duplicate, one out of order, an
empty or oversized one, or a first one that is not the start of a WebM file is refused
with a sentence and counted on the video (``refused``); nothing stored is touched.
"""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from pathlib import Path

from sqlalchemy import delete, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import ParticipantVideo, Study, VideoChunk
from chameleons.backend.studies.specs import spec_of
from chameleons.backend.video import storage
from chameleons.backend.video.repository import active_session
from chameleons.backend.video.schemas import BoothVideoState, Clock

MAX_CHUNK_BYTES = 16 * 1024 * 1024  # a 2 s timeslice of HD video is well under 2 MiB
CLOCK_TOLERANCE = timedelta(minutes=10)  # a mapped start further from now is a broken clock


class VideoRefusedError(Exception):
    """A request the recording page should not have made: ``status`` and a sentence."""

    def __init__(self, status: int, detail: str, problem: str = "refused") -> None:
        super().__init__(detail)
        self.status = status
        self.detail = detail
        self.problem = problem  # a word the page acts on: duplicate, out_of_order, ...


def booth_state(db: DbSession, booth: str, now: datetime | None = None) -> BoothVideoState:
    now = now or datetime.now(UTC)
    server_ms = now.timestamp() * 1000
    session = active_session(db, booth)
    if session is None:
        return BoothVideoState(server_ms=server_ms, reason="No session is running at this booth.")
    study = db.get(Study, session.study_id)
    spec = spec_of(study) if study is not None else None
    base = BoothVideoState(server_ms=server_ms, session_id=session.id)
    if spec is None or not spec.procedure.records_video:
        return base.model_copy(update={"reason": "This session's study does not record video."})
    if not session.video_consent:
        return base.model_copy(update={"reason": "The participant did not agree to be filmed."})
    return base.model_copy(update={"record": True, "audio": bool(session.video_audio_consent),
                                   "reason": "Recording this session."})  # fmt: skip


def start_video(db: DbSession, booth: str, session_id: int, mime_type: str, audio: bool,
                clock: Clock, now: datetime | None = None) -> ParticipantVideo:  # fmt: skip
    now = now or datetime.now(UTC)
    state = booth_state(db, booth, now)
    if state.session_id != session_id or not state.record:
        raise VideoRefusedError(409, f"Session {session_id} is not to be filmed at {booth} now: "
                                f"{state.reason}", "not_now")  # fmt: skip
    if audio and not state.audio:
        raise VideoRefusedError(403, "The participant did not agree to their voice being recorded: "
                                "record the video without the microphone.", "no_audio")  # fmt: skip
    if not mime_type.lower().startswith("video/webm"):
        raise VideoRefusedError(415, f"Only WebM video is stored (the recorder offers "
                                f"{mime_type!r}).", "not_webm")  # fmt: skip
    started_at = datetime.fromtimestamp((clock.start_ms + clock.offset_ms) / 1000, UTC)
    if abs(started_at - now) > CLOCK_TOLERANCE:
        raise VideoRefusedError(422, f"The page's clock maps the recorder's start to "
                                f"{started_at.isoformat()}, not near the server's "
                                f"{now.isoformat()}: reload the page.", "clock")  # fmt: skip
    video = ParticipantVideo(session_id=session_id, booth=booth, mime_type=mime_type,
                             audio=audio, path="", started_at=started_at,
                             clock={**clock.model_dump(),
                                    "received_at": now.isoformat()})  # fmt: skip
    db.add(video)
    db.flush()
    video.path = storage.relative_path(session_id, video.id)
    db.flush()
    return video


def _video_at(db: DbSession, booth: str, video_id: int) -> ParticipantVideo:
    query = select(ParticipantVideo).where(ParticipantVideo.id == video_id).with_for_update()
    video = db.scalars(query).first()
    if video is None or video.booth != booth:
        raise VideoRefusedError(404, f"There is no video {video_id} at {booth}.", "no_video")
    return video


def _refuse(db: DbSession, video: ParticipantVideo, status: int, detail: str,
            problem: str) -> VideoRefusedError:  # fmt: skip
    video.refused += 1
    db.flush()
    return VideoRefusedError(status, detail, problem)


def add_chunk(db: DbSession, booth: str, video_id: int, seq: int, data: bytes | None,
              media_ms: float | None, data_dir: Path) -> ParticipantVideo:  # fmt: skip
    """Store chunk ``seq`` (``None``: it was larger than :data:`MAX_CHUNK_BYTES`)."""
    video = _video_at(db, booth, video_id)
    if video.stopped_at is not None:
        raise _refuse(db, video, 409, f"Video {video_id} was stopped; start a new one.", "stopped")
    if data is None:
        raise _refuse(db, video, 413, f"Chunk {seq} is larger than {MAX_CHUNK_BYTES} bytes: "
                                      f"record with a shorter timeslice.", "too_large")  # fmt: skip
    if not data:
        raise _refuse(db, video, 422, f"Chunk {seq} is empty.", "empty")
    if seq < video.chunks:
        raise _refuse(db, video, 409, f"Chunk {seq} of video {video_id} is stored already "
                                      f"(a duplicate): send chunk {video.chunks} next.",
                       "duplicate")  # fmt: skip
    if seq > video.chunks:
        raise _refuse(db, video, 409, f"Chunk {seq} of video {video_id} came out of order: "
                                      f"chunk {video.chunks} comes next.",
                       "out_of_order")  # fmt: skip
    if seq == 0 and not data.startswith(storage.EBML_MAGIC):
        raise _refuse(db, video, 422, "Chunk 0 is not the start of a WebM file "
                                      "(no EBML header).", "not_webm")  # fmt: skip
    storage.append(data_dir / video.path, video.size_bytes, data)
    now = datetime.now(UTC)
    db.add(VideoChunk(video_id=video.id, seq=seq, offset=video.size_bytes, size=len(data),
                      media_ms=media_ms, received_at=now))  # fmt: skip
    video.chunks += 1
    video.size_bytes += len(data)
    video.last_chunk_at = now
    db.flush()
    return video


def stop_video(db: DbSession, booth: str, video_id: int) -> ParticipantVideo:
    video = _video_at(db, booth, video_id)
    if video.stopped_at is None:
        video.stopped_at = datetime.now(UTC)
        db.flush()
    return video


def videos_of(db: DbSession, session_id: int) -> list[ParticipantVideo]:
    """The session's videos with at least one chunk, in the order they were started."""
    query = (select(ParticipantVideo)
             .where(ParticipantVideo.session_id == session_id, ParticipantVideo.chunks > 0)
             .order_by(ParticipantVideo.started_at, ParticipantVideo.id))  # fmt: skip
    return list(db.scalars(query))


def last_media_ms(db: DbSession, video_id: int) -> float | None:
    """The page's media time at the end of the video's last chunk (its length, nearly)."""
    query = select(VideoChunk.media_ms).where(VideoChunk.video_id == video_id)
    return db.scalar(query.order_by(VideoChunk.seq.desc()).limit(1))


def forget_videos(db: DbSession, session_ids: list[int], data_dir: Path) -> int:
    """Withdrawal: delete the sessions' videos, rows and files; returns the files deleted."""
    if not session_ids:
        return 0
    ids = select(ParticipantVideo.id).where(ParticipantVideo.session_id.in_(session_ids))
    db.execute(delete(VideoChunk).where(VideoChunk.video_id.in_(ids)))
    db.execute(delete(ParticipantVideo).where(ParticipantVideo.session_id.in_(session_ids)))
    return sum(storage.delete_session_videos(data_dir, sid) for sid in session_ids)
