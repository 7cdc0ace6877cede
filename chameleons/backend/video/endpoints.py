"""The booth recording page's API, ``/api/video/<booth>/...``, keyed like the capture page:
the booth's capture key in the ``X-Booth-Key`` header (a wrong, rotated or retired key, or
an unknown booth, is a 404, as for the page itself).

- ``GET state``: what to record now (and the server's clock, for the page's offset);
- ``POST videos``: a new video of the running session (JSON :class:`VideoStart`);
- ``POST videos/<id>/chunks/<seq>?media_ms=``: one ``MediaRecorder`` chunk, the raw bytes
  as the body, in order from 0; refusals are counted on the video;
- ``POST videos/<id>/stop``: the recorder stopped (its last chunk came before).
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import Depends, Header, HTTPException, Query, Request, status
from fastapi.responses import JSONResponse

from chameleons.backend.capture import links
from chameleons.backend.dependencies import AppSettings, DbSession
from chameleons.backend.display.tokens import is_valid_booth
from chameleons.backend.routing import make_router
from chameleons.backend.video import service
from chameleons.backend.video.schemas import BoothVideoState, ChunkStored, VideoStart, VideoStarted

router = make_router(tags=["video"])
NO_SUCH = "No such booth recording link."
REFUSALS: dict[int | str, dict[str, Any]] = {
    404: {"description": "No such booth or video, or a wrong key"},
    409: {"description": "Duplicate, out of order, or not to be filmed now"},
}


def booth_key(request: Request, booth: str, db: DbSession,
              x_booth_key: Annotated[str | None, Header()] = None) -> str:  # fmt: skip
    """The booth, once its key checks out (the capture link's: it rotates and retires with
    the booth's display link)."""
    if not (is_valid_booth(booth) and x_booth_key
            and links.token_works(db, request.app, booth, x_booth_key)):  # fmt: skip
        raise HTTPException(status.HTTP_404_NOT_FOUND, NO_SUCH)
    return booth


Booth = Annotated[str, Depends(booth_key)]


async def chunk_body(request: Request) -> bytes | None:
    """The request's bytes; ``None`` once they pass :data:`service.MAX_CHUNK_BYTES` (the
    rest is not read into memory)."""
    declared = request.headers.get("content-length")
    if declared is not None and declared.isdigit() and int(declared) > service.MAX_CHUNK_BYTES:
        return None
    parts, size = [], 0
    async for part in request.stream():
        size += len(part)
        if size > service.MAX_CHUNK_BYTES:
            return None
        parts.append(part)
    return b"".join(parts)


def _refused(exc: service.VideoRefusedError) -> JSONResponse:
    # Returned, not raised: the refusal's count on the video is committed with it.
    return JSONResponse({"detail": exc.detail, "problem": exc.problem}, status_code=exc.status)


@router.get("/api/video/{booth}/state", responses=REFUSALS)
def video_state(booth: Booth, db: DbSession) -> BoothVideoState:
    """What the booth's recording page should record now."""
    return service.booth_state(db, booth)


@router.post("/api/video/{booth}/videos", status_code=status.HTTP_201_CREATED,
             responses=REFUSALS, response_model=VideoStarted)  # fmt: skip
def video_start(booth: Booth, data: VideoStart, db: DbSession) -> VideoStarted | JSONResponse:
    try:
        video = service.start_video(db, booth, data.session_id, data.mime_type, data.audio,
                                    data.clock)  # fmt: skip
    except service.VideoRefusedError as exc:
        return _refused(exc)
    return VideoStarted(video_id=video.id, started_at=video.started_at.isoformat())


@router.post("/api/video/{booth}/videos/{video_id}/chunks/{seq}", responses=REFUSALS,
             response_model=ChunkStored)  # fmt: skip
def video_chunk(
    booth: Booth,
    video_id: int,
    seq: int,
    db: DbSession,
    settings: AppSettings,
    body: Annotated[bytes | None, Depends(chunk_body)],
    media_ms: Annotated[float | None, Query(ge=0, le=1e9)] = None,
) -> ChunkStored | JSONResponse:
    if seq < 0:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, "A chunk's number is 0 or more.")
    try:
        video = service.add_chunk(db, booth, video_id, seq, body, media_ms, settings.data_dir)
    except service.VideoRefusedError as exc:
        return _refused(exc)
    return ChunkStored(video_id=video.id, seq=seq, size=len(body or b""), chunks=video.chunks,
                       size_bytes=video.size_bytes)  # fmt: skip


@router.post("/api/video/{booth}/videos/{video_id}/stop", responses=REFUSALS)
def video_stop(booth: Booth, video_id: int, db: DbSession) -> dict[str, int]:
    try:
        video = service.stop_video(db, booth, video_id)
    except service.VideoRefusedError as exc:
        raise HTTPException(exc.status, exc.detail) from exc
    return {"video_id": video.id, "chunks": video.chunks, "refused": video.refused}
