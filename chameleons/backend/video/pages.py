"""The booth's recording page, and the PI's replay: the video file and the faces.

- ``/video/<booth>/<key>``: the recording page (no login; the capture link's key, which
  rotates and retires with the booth's display link; a wrong one is a 404);
- ``/pi/sessions/<id>/videos/<video>.webm``: a video as stored (PI login; byte ranges,
  so the player can seek);
- ``/pi/sessions/<id>/replay.json``: what the session page's replay draws.
"""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from fastapi import HTTPException, Request, status
from fastapi.responses import FileResponse, HTMLResponse, Response
from sqlalchemy import select

from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.capture import links
from chameleons.backend.dependencies import AppSettings, DbSession, Templates
from chameleons.backend.display.tokens import is_valid_booth
from chameleons.backend.instruments.eaf import origin_of, session_marks
from chameleons.backend.models import Event, ParticipantVideo, Session
from chameleons.backend.routing import make_router
from chameleons.backend.video.curves import session_curves
from chameleons.backend.video.service import last_media_ms, videos_of

router = make_router(tags=["video"])
TIMESLICE_MS = 2000  # each chunk: 2 s of video (a crash loses at most that)


@router.get("/video/{booth}/{token}", response_class=HTMLResponse)
def recording_page(request: Request, booth: str, token: str, templates: Templates,
                   db: DbSession) -> Response:  # fmt: skip
    """The booth's participant-video recording page."""
    if not is_valid_booth(booth) or not links.token_works(db, request.app, booth, token):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such recording page.")
    context = {"booth": booth, "timeslice_ms": TIMESLICE_MS}
    response = templates.TemplateResponse(request, "video/record.html", context)
    response.headers["Referrer-Policy"] = "no-referrer"
    response.headers["Cache-Control"] = "no-store"
    response.headers["Permissions-Policy"] = "camera=(self), microphone=(self)"
    return response


def _session_or_404(db: DbSession, session_id: int) -> Session:
    session = db.get(Session, session_id)
    if session is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no session {session_id}.")
    return session


@router.get("/pi/sessions/{session_id}/videos/{video_id}.webm")
def video_file(session_id: int, video_id: int, _pi: CurrentPI, db: DbSession,
               settings: AppSettings) -> Response:  # fmt: skip
    video = db.get(ParticipantVideo, video_id)
    path = Path(settings.data_dir) / video.path if video is not None else None
    if video is None or video.session_id != session_id or path is None or not path.is_file():
        raise HTTPException(status.HTTP_404_NOT_FOUND,
                            f"Session {session_id} has no video {video_id}.")  # fmt: skip
    return FileResponse(path, media_type="video/webm",
                        headers={"Cache-Control": "no-store"})  # fmt: skip


@router.get("/pi/sessions/{session_id}/replay.json")
def replay(session_id: int, _pi: CurrentPI, db: DbSession,
           settings: AppSettings) -> dict[str, Any]:  # fmt: skip
    """The session's videos, faces and timeline, all in seconds from its origin (the
    ``.eaf`` files' origin: its first event or its start)."""
    session = _session_or_404(db, session_id)
    origin = origin_of(session, session_marks(db, session_id))
    videos = [{
        "id": v.id, "url": f"/pi/sessions/{session_id}/videos/{v.id}.webm",
        "start_s": round((_aware(v.started_at) - origin).total_seconds(), 3),
        "chunks": v.chunks, "size_bytes": v.size_bytes, "audio": v.audio, "refused": v.refused,
        "started_at": _aware(v.started_at).isoformat(),
        "duration_s": round((last_media_ms(db, v.id) or 0) / 1000, 3),
    } for v in videos_of(db, session_id)]  # fmt: skip
    events = [{"id": e.id, "kind": e.kind, "t": round((_aware(e.server_time) - origin)
                                                       .total_seconds(), 3)}
              for e in db.scalars(select(Event).where(Event.session_id == session_id)
                                  .order_by(Event.server_time, Event.id))]  # fmt: skip
    return {"origin": origin.isoformat(), "videos": videos, "events": events,
            "faces": session_curves(db, session_id, Path(settings.data_dir), origin)}  # fmt: skip


def _aware(moment: datetime) -> datetime:
    return moment if moment.tzinfo else moment.replace(tzinfo=UTC)


def current_video_path(app: Any, booth: str) -> str | None:
    """The booth's recording page: the capture page's key under ``/video/``; ``None`` when
    the booth is retired."""
    path = links.current_capture_path(app, booth)
    return None if path is None else "/video/" + path.removeprefix("/capture/")
