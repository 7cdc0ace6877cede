"""``chameleons export --video``: the participants' videos, only when asked, as WebM files
beside an index (``video/videos.csv``); and the videos an ``.eaf`` links to."""

from __future__ import annotations

import csv
import json
import shutil
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.instruments.eaf import LinkedMedia, origin_of, session_marks
from chameleons.backend.models import Participant, ParticipantVideo, Session

FOLDER = "video"
INDEX_COLUMNS = ("participant", "session_id", "video_id", "file", "started_at", "start_s",
                 "audio", "mime_type", "chunks", "size_bytes", "refused", "clock")  # fmt: skip


def _videos(db: DbSession, study_id: int,
            include_rehearsal: bool) -> Iterator[tuple[ParticipantVideo, str]]:  # fmt: skip
    query = (select(ParticipantVideo, Participant.code)
             .join(Session, Session.id == ParticipantVideo.session_id)
             .join(Participant, Participant.id == Session.participant_id)
             .where(Session.study_id == study_id, ParticipantVideo.chunks > 0)
             .order_by(Participant.code, ParticipantVideo.started_at,
                       ParticipantVideo.id))  # fmt: skip
    if not include_rehearsal:
        query = query.where(Session.is_rehearsal.is_(False))
    yield from db.execute(query).tuples()


def file_name(code: str, video: ParticipantVideo) -> str:
    return f"{code}-session{video.session_id}-video{video.id}.webm"


def export_videos(db: DbSession, study_id: int, include_rehearsal: bool, data_dir: Path,
                  out: Path) -> dict[int, list[LinkedMedia]]:  # fmt: skip
    """Copy each video to ``out/video/`` and index it; returns, per session, the copies for
    the ``.eaf`` files (``out/eaf/`` links them as ``../video/<name>``)."""
    folder = out / FOLDER
    rows, linked = [], dict[int, list[LinkedMedia]]()
    for video, code in _videos(db, study_id, include_rehearsal):
        source = data_dir / video.path
        if not source.is_file():
            continue
        name = file_name(code, video)
        folder.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(source, folder / name)
        session = db.get(Session, video.session_id)
        assert session is not None
        origin = origin_of(session, session_marks(db, session.id))
        start_s = (_aware(video.started_at) - origin).total_seconds()
        started = _aware(video.started_at).isoformat()
        clock = json.dumps(video.clock, sort_keys=True)
        rows.append([code, video.session_id, video.id, name, started, round(start_s, 3),
                     video.audio, video.mime_type, video.chunks, video.size_bytes,
                     video.refused, clock])  # fmt: skip
        linked.setdefault(video.session_id, []).append(
            LinkedMedia(folder / name, f"../{FOLDER}/{name}", video.started_at)
        )
    if rows:
        with (folder / "videos.csv").open("w", newline="", encoding="utf-8") as file:
            writer = csv.writer(file)
            writer.writerow(INDEX_COLUMNS)
            writer.writerows(rows)
    return linked


def stored_videos(db: DbSession, study_id: int, include_rehearsal: bool,
                  data_dir: Path) -> dict[int, list[LinkedMedia]]:  # fmt: skip
    """The videos where the server keeps them, for ``.eaf`` files exported without the
    videos (``MEDIA_URL`` names the server's file; no relative path)."""
    linked = dict[int, list[LinkedMedia]]()
    for video, _code in _videos(db, study_id, include_rehearsal):
        if (data_dir / video.path).is_file():
            linked.setdefault(video.session_id, []).append(
                LinkedMedia(data_dir / video.path, None, video.started_at)
            )
    return linked


def _aware(moment: datetime) -> datetime:
    return moment if moment.tzinfo else moment.replace(tzinfo=UTC)
