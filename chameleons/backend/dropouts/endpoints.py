"""PI actions on a dropout, kept in the data: exclude / include again, and hand the plan row
to a replacement. Forms for the dashboard, JSON for scripts; all need a PI and CSRF."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Form, HTTPException, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from pydantic import BaseModel, Field

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.dashboard.context import flash, page_context, study_or_404
from chameleons.backend.dependencies import DbSession, Templates
from chameleons.backend.dropouts import service
from chameleons.backend.dropouts.service import MAX_REASON
from chameleons.backend.routing import make_router
from chameleons.backend.studies.errors import FlowError, NotFoundError, http_errors

router = make_router(tags=["dropouts"])
CSRF = [Depends(verify_csrf)]


class ExclusionRequest(BaseModel):
    excluded: bool
    reason: str = Field(default="", max_length=MAX_REASON)


def _back(study_id: int) -> RedirectResponse:
    return RedirectResponse(f"/pi?study={study_id}", status_code=status.HTTP_303_SEE_OTHER)


@router.get("/pi/participants/{code}/exclude", response_class=HTMLResponse)
def exclude_form(
    request: Request, code: str, user: CurrentPI, db: DbSession, templates: Templates,
    study: int | None = None,
) -> Response:  # fmt: skip
    found = study_or_404(db, study)
    try:
        service.find(db, found.id, code)
    except NotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, exc.message) from exc
    context = page_context(request, user, found, "overview", code=code, error=None, reason="")
    return templates.TemplateResponse(request, "pi/exclude.html", context)


@router.post("/pi/participants/{code}/exclude", response_class=HTMLResponse, dependencies=CSRF)
def exclude_submit(
    request: Request, code: str, user: CurrentPI, db: DbSession, templates: Templates,
    reason: Annotated[str, Form(max_length=MAX_REASON)] = "", study: int | None = None,
) -> Response:  # fmt: skip
    found = study_or_404(db, study)
    try:
        service.exclude(db, found.id, code, reason)
    except NotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, exc.message) from exc
    except FlowError as exc:
        context = page_context(
            request, user, found, "overview", code=code, error=exc.message, reason=reason
        )
        return templates.TemplateResponse(
            request, "pi/exclude.html", context, status_code=status.HTTP_400_BAD_REQUEST
        )
    flash(request, f"{code} is excluded from the analysis ({reason.strip()}); no data deleted.")
    return _back(found.id)


@router.post("/pi/participants/{code}/include", dependencies=CSRF)
def include_submit(
    request: Request, code: str, _pi: CurrentPI, db: DbSession, study: int | None = None
) -> Response:
    found = study_or_404(db, study)
    try:
        service.include(db, found.id, code)
    except NotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, exc.message) from exc
    except FlowError as exc:
        flash(request, exc.message)
    else:
        flash(request, f"{code} is included in the analysis again.")
    return _back(found.id)


@router.post("/pi/participants/{code}/hand-on-row", dependencies=CSRF)
def hand_on_submit(
    request: Request, code: str, _pi: CurrentPI, db: DbSession, study: int | None = None
) -> Response:
    found = study_or_404(db, study)
    try:
        released = service.hand_on_row(db, found.id, code)
    except NotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, exc.message) from exc
    except FlowError as exc:
        flash(request, exc.message)
    else:
        flash(
            request,
            f"Plan row {released.row_number} goes to the next participant registered; "
            f"{code}'s data stay.",
        )
    return _back(found.id)


@router.post("/api/pi/participants/{code}/exclusion", dependencies=CSRF)
def exclusion_api(
    code: str, body: ExclusionRequest, _pi: CurrentPI, db: DbSession, study: int | None = None
) -> dict[str, object]:
    found = study_or_404(db, study)
    with http_errors():
        if body.excluded:
            participant = service.exclude(db, found.id, code, body.reason)
        else:
            participant = service.include(db, found.id, code)
        return {
            "participant": participant.code,
            "excluded": participant.excluded_at is not None,
            "reason": participant.exclusion_reason,
        }


@router.post("/api/pi/participants/{code}/hand-on-row", dependencies=CSRF)
def hand_on_api(
    code: str, _pi: CurrentPI, db: DbSession, study: int | None = None
) -> dict[str, object]:
    found = study_or_404(db, study)
    with http_errors():
        released = service.hand_on_row(db, found.id, code)
        return {"participant": released.participant, "row_number": released.row_number}
