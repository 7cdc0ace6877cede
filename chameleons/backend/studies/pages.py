"""Minimal PI pages: create a study from its YAML and generate or extend its plan.

The PI dashboard builds the overview pages; these forms post to the same service.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Form, HTTPException, Request, status
from fastapi.responses import HTMLResponse, RedirectResponse, Response

from chameleons.backend.auth.csrf import verify_csrf
from chameleons.backend.auth.dependencies import CurrentPI, CurrentStaff
from chameleons.backend.dependencies import DbSession, Templates
from chameleons.backend.events.unit_of_work import WriteDb
from chameleons.backend.routing import make_router
from chameleons.backend.studies import service
from chameleons.backend.studies.endpoints import spec_from_yaml, study_read
from chameleons.backend.studies.errors import FlowError
from chameleons.experiment.templates import study_templates

router = make_router(tags=["studies"])


def _render(
    request: Request, templates: Templates, db: DbSession, user: object, error: str | None = None
) -> Response:
    studies = [study_read(db, study, request.app.state) for study in service.list_studies(db)]
    return templates.TemplateResponse(
        request,
        "studies/studies.html",
        {"user": user, "studies": studies, "error": error, "templates": list(study_templates())},
        status_code=status.HTTP_200_OK if error is None else status.HTTP_409_CONFLICT,
    )


@router.get("/studies", response_class=HTMLResponse)
def studies_page(
    request: Request, user: CurrentStaff, db: DbSession, templates: Templates
) -> Response:
    return _render(request, templates, db, user)


@router.post("/studies", response_class=HTMLResponse, dependencies=[Depends(verify_csrf)])
def create_study_form(
    request: Request,
    user: CurrentPI,
    db: WriteDb,
    templates: Templates,
    study_yaml: Annotated[str, Form(max_length=1_000_000)] = "",
    template: Annotated[str, Form(max_length=64)] = "",
) -> Response:
    try:
        if template:  # a shipped template (issue 31), unless YAML was pasted as well
            found = study_templates().get(template)
            if found is None:
                return _render(request, templates, db, user, f"There is no template {template!r}.")
            study_yaml = study_yaml.strip() or found.read_text(encoding="utf-8")
        spec = spec_from_yaml(study_yaml.strip() or None)
        service.create_study(db, spec)
    except HTTPException as exc:
        detail = exc.detail
        problems = detail.get("problems", []) if isinstance(detail, dict) else [str(detail)]
        return _render(request, templates, db, user, "; ".join(problems))
    except FlowError as exc:
        return _render(request, templates, db, user, exc.message)
    return RedirectResponse("/studies", status_code=status.HTTP_303_SEE_OTHER)


@router.post(
    "/studies/{study_id}/plan", response_class=HTMLResponse, dependencies=[Depends(verify_csrf)]
)
def plan_form(
    study_id: int,
    request: Request,
    user: CurrentPI,
    db: WriteDb,
    templates: Templates,
    participants: Annotated[int, Form(ge=1, le=1000)],
) -> Response:
    try:
        service.generate_plan(db, service.get_study(db, study_id), participants)
    except FlowError as exc:
        return _render(request, templates, db, user, exc.message)
    return RedirectResponse("/studies", status_code=status.HTTP_303_SEE_OTHER)
