"""The analysis page, its plots (SVG/PNG/PDF), the LaTeX Table I and the JSON."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Path, Query, Request, status
from fastapi.responses import HTMLResponse, PlainTextResponse, Response
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.analysis.plots import (
    MEASURE_TITLES,
    MEDIA_TYPES,
    PlotFormat,
    paired_values,
    plot_measure,
)
from chameleons.backend.analysis.service import (
    ERROR_LABELS,
    StudyAnalysis,
    StudyScores,
    database_scores,
    study_analysis,
)
from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.dashboard.context import page_context, study_or_404
from chameleons.backend.dependencies import DbSession as Db
from chameleons.backend.dependencies import Templates
from chameleons.backend.export.selection import StudyNotFoundError
from chameleons.experiment.stats import bonferroni, friedman, order_conditions
from chameleons.experiment.stats.render_models import effect_sizes_latex, models_latex

router = APIRouter(tags=["analysis"])
MAX_PERMUTATIONS = 100_000
Permutations = Annotated[int | None, Query(ge=1, le=MAX_PERMUTATIONS)]


def _load(
    db: DbSession,
    study: int | None,
    include_rehearsal: bool,
    permutations: int | None = None,
    *,
    extended: bool = True,
) -> StudyAnalysis:
    try:
        return study_analysis(db, study, include_rehearsal, permutations, extended=extended)
    except StudyNotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from exc


def value_range(scores: StudyScores, measure: str) -> tuple[float, float]:
    if measure == "accepted":
        return 0.0, float(scores.spec.suggestions_per_interaction)
    return 1.0, float(scores.spec.questionnaire(measure).points)


def friedman_text(chi2: float | None, p_bonferroni: float | None, w: float | None) -> str:
    if chi2 is None or p_bonferroni is None:
        return "Friedman test undefined"
    text = f"Friedman \u03c7\u00b2 = {chi2:.2f}, p (Bonferroni) = {p_bonferroni:.3g}"
    return text + (f", W = {w:.2f}" if w is not None else "")


@router.get("/pi/analysis", response_class=HTMLResponse)
def analysis_page(
    request: Request,
    user: CurrentPI,
    db: Db,
    templates: Templates,
    study: int | None = None,
    include_rehearsal: bool = False,
    permutations: Permutations = None,
) -> Response:
    # The first render has the paper's analysis; the effect sizes and models (about a
    # second for a large study) arrive from /pi/analysis/extended after it.
    result = _load(db, study, include_rehearsal, permutations, extended=False)
    found = study_or_404(db, result.scores.study.id)
    query = f"?study={found.id}" + ("&include_rehearsal=true" if include_rehearsal else "")
    context = page_context(
        request,
        user,
        found,
        "analysis",
        result=result,
        analysis=result.analysis,
        plot_query=query,
        include_rehearsal=include_rehearsal,
        permutations=permutations,
        measure_titles=MEASURE_TITLES,
        error_labels=ERROR_LABELS,
    )
    return templates.TemplateResponse(request, "pi/analysis.html", context)


@router.get("/pi/analysis/extended", response_class=HTMLResponse)
def analysis_extended(
    request: Request,
    _pi: CurrentPI,
    db: Db,
    templates: Templates,
    study: int | None = None,
    include_rehearsal: bool = False,
    permutations: Permutations = None,
) -> Response:
    """The page's effect-size and model sections (an HTML fragment the page fetches)."""
    result = _load(db, study, include_rehearsal, permutations)
    labels = result.scores.condition_labels
    latex = (
        "\n".join(
            effect_sizes_latex(result.analysis, labels) + models_latex(result.analysis, labels)
        )
        if result.analysis
        else ""
    )
    context = {
        "result": result,
        "analysis": result.analysis,
        "measure_titles": MEASURE_TITLES,
        "extended_latex": latex,
    }
    return templates.TemplateResponse(
        request, "pi/analysis_extended.html", context, headers={"Cache-Control": "no-store"}
    )


@router.get("/pi/analysis/plots/{measure}.{fmt}")
def analysis_plot(
    measure: Annotated[str, Path(pattern=r"^[a-z0-9_]+$")],
    fmt: PlotFormat,
    _pi: CurrentPI,
    db: Db,
    study: int | None = None,
    include_rehearsal: bool = False,
) -> Response:
    try:
        scores = database_scores(db, study, include_rehearsal)
    except StudyNotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from exc
    if measure not in scores.measures:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no measure {measure!r}.")
    # Only the omnibus test for the subtitle: post-hoc tests are not needed for a plot.
    conditions = order_conditions({str(row["condition"]) for row in scores.rows})
    test = friedman(paired_values(scores.rows, measure, conditions))
    image = plot_measure(
        scores.rows,
        measure,
        conditions,
        scores.condition_labels,
        value_range(scores, measure),
        friedman_text(test.chi2, bonferroni(test.p, len(scores.measures)), test.kendall_w),
        fmt,
    )
    name = f"{measure}-study{scores.study.id}.{fmt}"
    headers = {"Content-Disposition": f'inline; filename="{name}"', "Cache-Control": "no-store"}
    return Response(image, media_type=MEDIA_TYPES[fmt], headers=headers)


@router.get("/pi/analysis/table1.tex", response_class=PlainTextResponse)
def table_latex(
    _pi: CurrentPI, db: Db, study: int | None = None, include_rehearsal: bool = False
) -> PlainTextResponse:
    result = _load(db, study, include_rehearsal)
    if result.analysis is None:
        raise HTTPException(status.HTTP_409_CONFLICT, result.error or "No analysis.")
    return PlainTextResponse(result.latex + "\n")


@router.get("/api/pi/analysis")
def analysis_api(
    _pi: CurrentPI,
    db: Db,
    study: int | None = None,
    include_rehearsal: bool = False,
    permutations: Permutations = None,
) -> dict[str, Any]:
    result = _load(db, study, include_rehearsal, permutations)
    errors = {
        column: {c: d.__dict__ for c, d in per_condition.items()}
        for column, per_condition in result.errors.items()
    }
    return {
        "study": {"id": result.scores.study.id, "config_hash": result.scores.study.config_hash},
        "include_rehearsal": include_rehearsal,
        "error": result.error,
        "analysis": result.analysis.to_dict() if result.analysis else None,
        "error_scores": errors,
        "latex": result.latex,
    }
