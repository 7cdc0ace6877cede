"""The PI's planning pages: power by simulation (``/pi/power``, JSON twin) and the
preregistration document (``/pi/prereg.md``).

The form is a GET form: its query string is the whole request, so a result page can be
bookmarked and the preregistration link repeats it. Values a person typed wrongly come
back on the form with a sentence each, never as a server error.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from fastapi import HTTPException, Request, status
from fastapi.responses import HTMLResponse, JSONResponse, PlainTextResponse, Response

from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.dashboard.context import page_context, study_or_404
from chameleons.backend.dependencies import DbSession as Db
from chameleons.backend.dependencies import Templates
from chameleons.backend.models import Study
from chameleons.backend.planning.service import (
    PowerBusyError,
    power_result,
    preregistration_markdown,
)
from chameleons.backend.routing import make_router
from chameleons.experiment.model import Study as StudySpec
from chameleons.experiment.stats.power import TEST_LABELS, TESTS, PowerError
from chameleons.experiment.stats.power_render import pilot_assumptions
from chameleons.experiment.stats.power_service import PowerRequest
from chameleons.experiment.stats.render_models import number_text
from chameleons.experiment.study import study_from_config

router = make_router(tags=["planning"])
UNPROCESSABLE = 422  # the values cannot be used (Starlette renamed the constant)
MAX_REPLICATES = 5000
MAX_MODEL_REPLICATES = 500
MAX_SIZES = 8
MAX_N = 240


@dataclass
class PowerForm:
    """The form's values as typed (strings), and what is wrong with them."""

    values: dict[str, str]
    errors: list[str] = field(default_factory=list)
    request: PowerRequest | None = None


def default_values(spec: StudySpec) -> dict[str, str]:
    pilot = pilot_assumptions(spec)
    values = {
        "accept_sd": "1.0",
        "score_sd_between": "0.7",
        "score_sd_within": "0.7",
        "n": "12, 24, 36, 48, 60",
        "replicates": "1000",
        "model_replicates": "100",
        "alpha": "0.05",
        "tests": str(len(spec.measures)),
        "target": "0.8",
        "seed": "0",
    }
    for c in spec.condition_ids:
        values[f"accept_{c}"] = f"{pilot.acceptance[c]:.3f}" if pilot else "0.5"
        values[f"score_{c}"] = f"{pilot.scores[c]:g}" if pilot else "4.0"
    return values


def read_form(spec: StudySpec, query: dict[str, str], plan_seed: int) -> PowerForm:
    form = PowerForm({**default_values(spec), **{k: v.strip() for k, v in query.items()}})

    def number(name: str, what: str, low: float, high: float) -> float:
        text = form.values.get(name, "")
        try:
            value = float(text)
        except ValueError:
            form.errors.append(f"{what}: {text!r} is not a number.")
            return low
        if not low <= value <= high:
            form.errors.append(f"{what} must be between {low:g} and {high:g} (got {text}).")
        return value

    def whole(name: str, what: str, low: int, high: int) -> int:
        value = number(name, what, low, high)
        if value != int(value):
            form.errors.append(f"{what} must be a whole number.")
        return int(value)

    labels = {c.id: c.label for c in spec.conditions}
    acceptance = {
        c: number(f"accept_{c}", f"P(accept) for {labels[c]}", 0.001, 0.999)
        for c in spec.condition_ids
    }
    points = max((q.points for q in spec.questionnaires_for("interaction")), default=7)
    scores = {c: number(f"score_{c}", f"Mean score for {labels[c]}", 1, points)
              for c in spec.condition_ids}  # fmt: skip
    sizes = _sizes(form)
    if form.errors:
        return form
    try:
        form.request = PowerRequest.for_study(
            spec,
            acceptance=acceptance,
            scores=scores,
            acceptance_sd=number("accept_sd", "SD of acceptance tendencies", 0, 5),
            score_sd_between=number("score_sd_between", "Score SD between participants", 0, 5),
            score_sd_within=number("score_sd_within", "Score SD within participants", 0.01, 5),
            sample_sizes=sizes,
            replicates=whole("replicates", "Simulated studies per N", 100, MAX_REPLICATES),
            model_replicates=whole(
                "model_replicates", "Simulated studies for the GEE", 0, MAX_MODEL_REPLICATES
            ),
            alpha=number("alpha", "alpha", 0.0001, 0.5),
            tests=whole("tests", "Tests (Bonferroni)", 1, 50),
            target=number("target", "Target power", 0.5, 0.99),
            seed=whole("seed", "Seed", 0, 2**31 - 1),
            plan_seed=plan_seed,
        )
    except PowerError as exc:
        form.errors.append(str(exc))
    if form.errors:
        form.request = None
    return form


def _sizes(form: PowerForm) -> tuple[int, ...]:
    text = form.values.get("n", "")
    try:
        sizes = tuple(sorted({int(part) for part in text.replace(" ", "").split(",") if part}))
    except ValueError:
        form.errors.append(f"Sample sizes: {text!r} is not a list of whole numbers like 12, 24.")
        return ()
    if not sizes or len(sizes) > MAX_SIZES or sizes[0] < 2 or sizes[-1] > MAX_N:
        form.errors.append(f"Sample sizes: 1 to {MAX_SIZES} numbers between 2 and {MAX_N}.")
    return sizes


def _study(db: Db, study: int | None) -> tuple[Study, StudySpec]:
    found = study_or_404(db, study)
    return found, study_from_config(found.config)


async def _run(found: Study, form: PowerForm) -> dict[str, Any]:
    assert form.request is not None
    try:
        return await power_result(found, form.request)
    except PowerBusyError as exc:
        raise HTTPException(status.HTTP_429_TOO_MANY_REQUESTS, str(exc)) from exc
    except PowerError as exc:
        raise HTTPException(UNPROCESSABLE, str(exc)) from exc


def _query(request: Request) -> dict[str, str]:
    return {k: v for k, v in request.query_params.items() if k not in {"study", "run"}}


@router.get("/pi/power", response_class=HTMLResponse)
async def power_page(
    request: Request, user: CurrentPI, db: Db, templates: Templates, study: int | None = None
) -> Response:
    found, spec = _study(db, study)
    form = read_form(spec, _query(request), found.plan_seed)
    result, error = None, None
    if "run" in request.query_params and form.request is not None:
        try:
            result = await _run(found, form)
        except HTTPException as exc:
            error = str(exc.detail)
    context = page_context(
        request,
        user,
        found,
        "power",
        spec=spec,
        form=form,
        result=result,
        error=error,
        tests=TESTS,
        test_labels=TEST_LABELS,
        query=request.url.query,
        number=number_text,
    )
    code = UNPROCESSABLE if form.errors else status.HTTP_200_OK
    return templates.TemplateResponse(request, "pi/power.html", context, status_code=code)


@router.get("/api/pi/power")
async def power_json(
    request: Request, _pi: CurrentPI, db: Db, study: int | None = None
) -> JSONResponse:
    found, spec = _study(db, study)
    form = read_form(spec, _query(request), found.plan_seed)
    if form.request is None:
        raise HTTPException(UNPROCESSABLE, " ".join(form.errors))
    return JSONResponse(await _run(found, form))


@router.get("/pi/prereg.md", response_class=PlainTextResponse)
async def preregistration_download(
    request: Request, _pi: CurrentPI, db: Db, study: int | None = None
) -> PlainTextResponse:
    """The preregistration; with the power form's values (``run``), its power table."""
    found, spec = _study(db, study)
    power = None
    if "run" in request.query_params:
        form = read_form(spec, _query(request), found.plan_seed)
        if form.request is None:
            raise HTTPException(UNPROCESSABLE, " ".join(form.errors))
        power = await _run(found, form)
    text = preregistration_markdown(db, found, power)
    name = f"preregistration-study{found.id}.md"
    headers = {"Content-Disposition": f'attachment; filename="{name}"', "Cache-Control": "no-store"}
    return PlainTextResponse(text, media_type="text/markdown; charset=utf-8", headers=headers)
