"""One power request (the assumptions and settings a PI or the CLI gives) run against a
study: its conditions, suggestions per interaction and counterbalancing plan."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

from chameleons.experiment.blocks import balance_period
from chameleons.experiment.model import Study
from chameleons.experiment.stats.power import (
    Assumptions,
    PowerError,
    PowerResult,
    Progress,
    Settings,
    default_sample_sizes,
    planned_design,
    simulate,
)
from chameleons.experiment.stats.power_render import pilot_assumptions


@dataclass(frozen=True)
class PowerRequest:
    assumptions: Assumptions
    settings: Settings
    reference: str | None = None
    plan_seed: int = 0
    notes: tuple[str, ...] = field(default=())

    @classmethod
    def for_study(
        cls,
        study: Study,
        *,
        acceptance: Mapping[str, float] | None = None,
        scores: Mapping[str, float] | None = None,
        acceptance_sd: float = 1.0,
        score_sd_between: float = 0.7,
        score_sd_within: float = 0.7,
        sample_sizes: tuple[int, ...] | None = None,
        replicates: int = 2000,
        model_replicates: int = 200,
        alpha: float = 0.05,
        tests: int | None = None,
        target: float = 0.8,
        reference: str | None = None,
        seed: int = 0,
        plan_seed: int = 0,
    ) -> PowerRequest:
        """Missing effects come from the paper's pilot (for the paper's conditions)."""
        pilot = pilot_assumptions(study)
        notes = []
        if not acceptance or not scores:
            if pilot is None:
                raise PowerError("give an acceptance probability and a mean score per condition")
            notes.append("effects not given are the paper's pilot estimates (Table I)")
        points = max((q.points for q in study.questionnaires_for("interaction")), default=7)
        assumptions = Assumptions(
            acceptance=dict(acceptance or (pilot.acceptance if pilot else {})),
            scores=dict(scores or (pilot.scores if pilot else {})),
            acceptance_sd=acceptance_sd,
            score_sd_between=score_sd_between,
            score_sd_within=score_sd_within,
            scale=(1.0, float(points)),
        )
        settings = Settings(
            sample_sizes=sample_sizes or default_sample_sizes(study),
            replicates=replicates,
            model_replicates=model_replicates,
            alpha=alpha,
            tests=tests or len(study.measures),
            target=target,
            seed=seed,
        )
        return cls(assumptions, settings, reference, plan_seed, tuple(notes))

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def run_power(study: Study, request: PowerRequest, progress: Progress | None = None) -> PowerResult:
    designs = {
        n: planned_design(study, n, request.plan_seed) for n in request.settings.sample_sizes
    }
    reference = request.reference or ("still" if "still" in study.condition_ids else None)
    result = simulate(designs, request.assumptions, request.settings, reference, progress)
    period = balance_period(study)
    result.design.update(
        study=study.id,
        study_hash=study.content_hash,
        plan_seed=request.plan_seed,
        balance_period=period,
    )
    off = [n for n in request.settings.sample_sizes if n % period]
    if off:
        result.notes.append(
            f"N = {', '.join(map(str, off))} is not a multiple of the balance period ({period}): "
            "the plan is balanced only within one count there"
        )
    result.notes[:0] = list(request.notes)
    return result
