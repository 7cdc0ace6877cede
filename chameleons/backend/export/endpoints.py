"""The export download: a zip bundle streamed to the PI's browser."""

from __future__ import annotations

from typing import Annotated

from fastapi import HTTPException, Query, Request, status
from fastapi.responses import StreamingResponse
from sqlalchemy.orm import Session as DbSession
from sqlalchemy.orm import sessionmaker

from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.export.selection import StudyNotFoundError
from chameleons.backend.export.service import ExportFormat, ExportRequest, stream_zip
from chameleons.backend.routing import make_router
from chameleons.prompts.locations import prompts_root

router = make_router(prefix="/api/pi", tags=["export"])


@router.get("/export.zip", response_class=StreamingResponse)
def export_zip(
    request: Request,
    _pi: CurrentPI,
    format: Annotated[list[ExportFormat] | None, Query()] = None,
    include_rehearsal: bool = False,
    study: int | None = None,
    raw_csv: bool = False,
) -> StreamingResponse:
    """The study's tables (CSV plus the asked formats), codebook, config and metadata."""
    factory: sessionmaker[DbSession] = request.app.state.sessionmaker
    formats: tuple[ExportFormat, ...] = ("csv", *(f for f in format or [] if f != "csv"))
    export = ExportRequest(
        study_id=study, formats=formats, include_rehearsal=include_rehearsal, raw_csv=raw_csv,
        prompts_dir=prompts_root(request.app.state.settings),
    )  # fmt: skip
    try:
        name, chunks = stream_zip(factory, export)
    except StudyNotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from exc
    headers = {"Content-Disposition": f'attachment; filename="{name}"', "Cache-Control": "no-store"}
    return StreamingResponse(chunks, media_type="application/zip", headers=headers)
