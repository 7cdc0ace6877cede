"""The session page's instrument plots (PI only): each imported XDF stream under the
timeline (docs/instruments.md)."""

from __future__ import annotations

from pathlib import Path

from fastapi import HTTPException, status
from fastapi.responses import Response
from sqlalchemy import select

from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.dependencies import AppSettings, DbSession
from chameleons.backend.instruments.plots import plot_stream
from chameleons.backend.models import Event, InstrumentStream, Session
from chameleons.backend.routing import make_router

router = make_router(tags=["instruments"])


@router.get("/pi/sessions/{session_id}/instruments/{stream_id}.svg")
def instrument_plot(session_id: int, stream_id: int, _pi: CurrentPI, db: DbSession,
                    settings: AppSettings) -> Response:  # fmt: skip
    stream = db.get(InstrumentStream, stream_id)
    session = db.get(Session, session_id)
    data_dir = Path(settings.data_dir)
    if (stream is None or session is None or stream.session_id != session_id
            or not (data_dir / stream.path).is_file()):  # fmt: skip
        missing = f"Session {session_id} has no instrument stream {stream_id}."
        raise HTTPException(status.HTTP_404_NOT_FOUND, missing)
    times = list(db.scalars(select(Event.server_time).where(Event.session_id == session_id)
                            .order_by(Event.server_time)))  # fmt: skip
    zero = session.started_at or (times[0] if times else None)
    moments = [(t - zero).total_seconds() for t in times] if zero is not None else []
    ends = [m for m in (*moments, stream.first_s, stream.last_s) if m is not None]
    span = (min(0.0, *ends), max(ends)) if ends else None
    image = plot_stream(stream, data_dir, moments, span)
    return Response(image, media_type="image/svg+xml", headers={"Cache-Control": "no-store"})
