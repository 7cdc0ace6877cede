"""The analysis page, its plots (SVG/PNG/PDF), the LaTeX Table I and the JSON."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import HTTPException, Path, Query, Request, status
from fastapi.responses import HTMLResponse, PlainTextResponse, Response
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.analysis.plots import (
    MEASURE_TITLES,
    MEDIA_TYPES,
    PlotFormat,
    plot_measure,
)
from chameleons.backend.analysis.service import (
    ERROR_LABELS,
    StudyAnalysis,
    StudyScores,
    database_scores,
    run_analysis,
    study_analysis,
)
from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.dashboard.context import page_context, study_or_404
from chameleons.backend.dependencies import DbSession as Db
from chameleons.backend.dependencies import Templates
from chameleons.backend.export.selection import StudyNotFoundError
from chameleons.backend.instruments.reliability import study_reliability
from chameleons.backend.routing import make_router
from chameleons.experiment.stats import (
    DEFAULT_RULE,
    DEFAULT_VIEW,
    VIEW_TITLES,
    VIEWS,
    AnalysisError,
    View,
    WilcoxonRule,
    fmt_p,
)
from chameleons.experiment.stats import fmt as fmt_number
from chameleons.experiment.stats.render import posthoc_text
from chameleons.experiment.stats.render_models import (
    effect_sizes_latex,
    mix_test_text,
    models_latex,
    number_text,
    p_text,
)
from chameleons.experiment.stats.rounding import RULE

router = make_router(tags=["analysis"])
MAX_PERMUTATIONS = 100_000
Permutations = Annotated[int | None, Query(ge=1, le=MAX_PERMUTATIONS)]
ViewQuery = Annotated[View, Query(description="as_planned (intention to treat) or as_run")]
RuleQuery = Annotated[WilcoxonRule, Query(description="R version whose wilcox.test to follow")]


def _load(
    db: DbSession,
    study: int | None,
    include_rehearsal: bool,
    permutations: int | None = None,
    view: View = DEFAULT_VIEW,
    wilcoxon: WilcoxonRule = DEFAULT_RULE,
    *,
    extended: bool = True,
) -> StudyAnalysis:
    try:
        return study_analysis(
            db, study, include_rehearsal, permutations, view, wilcoxon, extended=extended
        )
    except StudyNotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from exc


def _query(
    study: int, include_rehearsal: bool, view: View, wilcoxon: WilcoxonRule = DEFAULT_RULE
) -> str:
    """The page's query string: what every link and plot of the page must repeat."""
    query = f"?study={study}&view={view}"
    if include_rehearsal:
        query += "&include_rehearsal=true"
    if wilcoxon != DEFAULT_RULE:
        query += f"&wilcoxon={wilcoxon.replace('>', '%3E').replace('<', '%3C')}"
    return query


def value_range(scores: StudyScores, measure: str) -> tuple[float, float]:
    if measure == "accepted":
        return 0.0, float(scores.spec.suggestions_per_interaction)
    return 1.0, float(scores.spec.questionnaire(measure).points)


SHORT_P_NAMES = {
    "exact permutation": "exact",
    "Monte Carlo permutation": "permutation",
    "asymptotic chi-squared": "asymptotic",
}


def friedman_text(
    chi2: float | None, p_bonferroni: float | None, w: float | None, how: str = ""
) -> str:
    """The plot's subtitle; ``how``: which p it is (the analysis's primary p)."""
    if chi2 is None or p_bonferroni is None:
        return "Friedman test undefined"
    label = f"{how} p" if how else "p"
    text = f"Friedman \u03c7\u00b2 = {fmt_number(chi2, 2)}, {label} (Bonferroni) = "
    text += fmt_p(p_bonferroni)
    return text + (f", W = {fmt_number(w, 3)}" if w is not None else "")


@router.get("/pi/analysis", response_class=HTMLResponse)
def analysis_page(
    request: Request,
    user: CurrentPI,
    db: Db,
    templates: Templates,
    study: int | None = None,
    include_rehearsal: bool = False,
    permutations: Permutations = None,
    view: ViewQuery = DEFAULT_VIEW,
    wilcoxon: RuleQuery = DEFAULT_RULE,
) -> Response:
    # The first render has the paper's analysis; the effect sizes and models (about a
    # second for a large study) arrive from /pi/analysis/extended after it.
    result = _load(db, study, include_rehearsal, permutations, view, wilcoxon, extended=False)
    found = study_or_404(db, result.scores.study.id)
    query = _query(found.id, include_rehearsal, view, wilcoxon)
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
        view=view,
        views=VIEW_TITLES,
        default_view=DEFAULT_VIEW,
        view_links={v: _query(found.id, include_rehearsal, v, wilcoxon) for v in VIEWS},
        rehearsal_link=_query(found.id, not include_rehearsal, view, wilcoxon),
        fmt=fmt_number,
        fmt_p=fmt_p,
        posthoc_text=posthoc_text,
        rounding_rule=RULE,
        reliability=study_reliability(db, found.id),  # coders' ELAN agreement (issue 33)
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
    view: ViewQuery = DEFAULT_VIEW,
    wilcoxon: RuleQuery = DEFAULT_RULE,
) -> Response:
    """The page's effect-size and model sections (an HTML fragment the page fetches)."""
    result = _load(db, study, include_rehearsal, permutations, view, wilcoxon)
    labels = result.scores.condition_labels
    latex = ""
    if result.analysis:
        tables = effect_sizes_latex(result.analysis, labels) + models_latex(result.analysis, labels)
        latex = "\n".join(tables)
    context = {
        "result": result,
        "analysis": result.analysis,
        "measure_titles": MEASURE_TITLES,
        "extended_latex": latex,
        "number": number_text,
        "p_text": p_text,
        "mix_test_text": mix_test_text,
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
    view: ViewQuery = DEFAULT_VIEW,
    wilcoxon: RuleQuery = DEFAULT_RULE,
) -> Response:
    try:
        scores = database_scores(db, study, include_rehearsal)
    except StudyNotFoundError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from exc
    if measure not in scores.measures:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no measure {measure!r}.")
    try:
        # The same analysis as the page (same view, same participants), without the extras.
        whole = run_analysis(scores, view=view, wilcoxon_rule=wilcoxon)
    except AnalysisError as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, f"The analysis cannot run: {exc}") from exc
    if measure not in whole.measures:
        raise HTTPException(status.HTTP_409_CONFLICT, f"There are no {measure} values yet.")
    analysis = whole.measures[measure]
    test = analysis.friedman
    _, p_bonferroni, how = analysis.primary_p
    image = plot_measure(
        list(analysis.values.values()),
        measure,
        whole.conditions,
        scores.condition_labels,
        value_range(scores, measure),
        friedman_text(test.chi2, p_bonferroni, test.kendall_w, SHORT_P_NAMES.get(how, "")),
        fmt,
    )
    name = f"{measure}-study{scores.study.id}-{view}.{fmt}"
    headers = {"Content-Disposition": f'inline; filename="{name}"', "Cache-Control": "no-store"}
    return Response(image, media_type=MEDIA_TYPES[fmt], headers=headers)


@router.get("/pi/analysis/table1.tex", response_class=PlainTextResponse)
def table_latex(
    _pi: CurrentPI,
    db: Db,
    study: int | None = None,
    include_rehearsal: bool = False,
    view: ViewQuery = DEFAULT_VIEW,
    wilcoxon: RuleQuery = DEFAULT_RULE,
) -> PlainTextResponse:
    result = _load(db, study, include_rehearsal, None, view, wilcoxon)
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
    view: ViewQuery = DEFAULT_VIEW,
    wilcoxon: RuleQuery = DEFAULT_RULE,
) -> dict[str, Any]:
    result = _load(db, study, include_rehearsal, permutations, view, wilcoxon)
    errors = {
        column: {c: d.to_dict() for c, d in per_condition.items()}
        for column, per_condition in result.errors.items()
    }
    return {
        "study": {"id": result.scores.study.id, "config_hash": result.scores.study.config_hash},
        "include_rehearsal": include_rehearsal,
        "view": view,
        "error": result.error,
        "analysis": result.analysis.to_dict() if result.analysis else None,
        "manipulation_check": [summary.to_dict() for summary in result.manipulation],
        "error_scores": errors,
        "robot_behaviour": [c.to_dict() for c in result.behaviour],
        "latex": result.latex,
    }
