"""The session page's synchrony plot and the analysis page's synchrony section (PI only)."""

from __future__ import annotations

from typing import Annotated

from fastapi import HTTPException, Query, Request, status
from fastapi.responses import HTMLResponse, Response

from chameleons.backend.analysis.plots import MEASURE_TITLES
from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.dependencies import DbSession, Templates
from chameleons.backend.export.selection import StudyNotFoundError, resolve_study
from chameleons.backend.routing import make_router
from chameleons.backend.synchrony import repository
from chameleons.backend.synchrony.analysis import study_synchrony
from chameleons.backend.synchrony.plots import plot_synchrony
from chameleons.experiment.stats import DEFAULT_VIEW, View
from chameleons.experiment.stats.measures import study_measures
from chameleons.experiment.stats.render_models import number_text, p_text
from chameleons.experiment.study import study_from_config
from chameleons.worker.behaviours.copy_params import nominal_delay

router = make_router(tags=["synchrony"])


@router.get("/pi/interactions/{interaction_id}/synchrony.svg")
def synchrony_plot(interaction_id: int, _pi: CurrentPI, db: DbSession) -> Response:
    found = repository.context(db, interaction_id)
    row = repository.stored(db, [interaction_id]).get(interaction_id)
    if found is None or row is None or not row.curves.get("curve"):
        raise HTTPException(status.HTTP_404_NOT_FOUND,
                            f"Interaction {interaction_id} has no synchrony curve.")  # fmt: skip
    condition = study_from_config(found.study.config).condition(found.interaction.condition)
    delay = None
    if condition.behaviour == "copy":
        delay = nominal_delay(condition.params)
    title = (f"Interaction {found.interaction.position} ({found.interaction.condition}): "
             f"{row.surrogate_count} {row.surrogate_kind} surrogates")  # fmt: skip
    image = plot_synchrony(row.curves, title, delay=delay)
    return Response(image, media_type="image/svg+xml", headers={"Cache-Control": "no-store"})


@router.get("/pi/analysis/synchrony", response_class=HTMLResponse)
def synchrony_section(
    request: Request,
    _pi: CurrentPI,
    db: DbSession,
    templates: Templates,
    study: int | None = None,
    include_rehearsal: bool = False,
    view: Annotated[View, Query(description="as_planned or as_run")] = DEFAULT_VIEW,
) -> Response:
    """The analysis page's synchrony section (an HTML fragment the page fetches)."""
    try:
        found = resolve_study(db, study)
    except StudyNotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from exc
    context = {
        "synchrony": study_synchrony(db, found.id, include_rehearsal, view),
        "labels": study_measures(study_from_config(found.config)).labels,
        "measure_titles": MEASURE_TITLES,
        "number": number_text,
        "p_text": p_text,
    }
    return templates.TemplateResponse(
        request, "pi/analysis_synchrony.html", context, headers={"Cache-Control": "no-store"}
    )
