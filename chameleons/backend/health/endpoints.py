"""Liveness with substance: 200 only when the database answers and its schema is at head."""

from __future__ import annotations

from fastapi import Request
from fastapi.responses import JSONResponse
from sqlalchemy import Engine
from sqlalchemy.exc import SQLAlchemyError

from chameleons import __version__
from chameleons.backend.migrate import current_revision, head_revision
from chameleons.backend.routing import make_router

router = make_router(tags=["health"])


@router.get("/healthz")
def healthz(request: Request) -> JSONResponse:
    engine: Engine = request.app.state.engine
    head = head_revision()
    try:
        current = current_revision(engine)
    except SQLAlchemyError as exc:
        reason = f"database unreachable: {type(exc).__name__}"
        return JSONResponse({"status": "error", "reason": reason}, status_code=503)
    if current != head:
        reason = f"schema at {current or 'nothing'}, expected {head}: run `chameleons db upgrade`"
        return JSONResponse({"status": "error", "reason": reason}, status_code=503)
    return JSONResponse({"status": "ok", "schema": current, "version": __version__})
