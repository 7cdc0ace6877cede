"""The synchrony analysis as text (``chameleons analyze``)."""

from __future__ import annotations

import math
from collections.abc import Mapping

from chameleons.experiment.stats.models import ModelResult
from chameleons.experiment.stats.rounding import fmt, fmt_p
from chameleons.experiment.stats.synchrony.outcomes import SynchronyAnalysis


def render_synchrony_text(analysis: SynchronyAnalysis, labels: Mapping[str, str]) -> str:
    lines = ["", "Synchrony of the faces (robot following the participant; the participant's "
             f"mimicry, surrogate-corrected), {analysis.participants} participants, "
             f"{analysis.view.replace('_', ' ')}:"]  # fmt: skip
    for c in analysis.conditions:
        checks = ", ".join(f"{k} {v}" for k, v in sorted(c.checks.items())) or "none"
        missing = ", ".join(f"{k} {v}" for k, v in sorted(c.missing.items())) or "none"
        lines.append(
            f"  {labels.get(c.condition, c.condition):<10} {c.interactions} interactions: "
            f"sync_r {c.sync_r.cell(2)}; sync_lag_s median {fmt(c.sync_lag_s.median, 2, '--')}; "
            f"mimicry_r {c.mimicry_r.cell(3)}; copy checks: {checks}; missing: {missing}"
        )  # fmt: skip
    if analysis.mimicry_model is not None:
        lines += _model(analysis.mimicry_model, labels)
    for model in analysis.covariate_models.values():
        lines += _model(model, labels)
    lines += [f"  note: {n}" for n in analysis.notes]
    return "\n".join(lines)


def _model(model: ModelResult, labels: Mapping[str, str]) -> list[str]:
    head = f"  {model.formula}"
    if model.error:
        return [head, f"    not available: {model.error}"]
    lines = [head + f"  ({model.n_observations} observations, {model.n_participants} "
             "participants)"]  # fmt: skip
    for c in model.coefficients:
        name = "intercept" if c.term == "Intercept" else (
            f"{c.term} = {labels.get(c.level, c.level)}" if c.level else c.term)  # fmt: skip
        lines.append(
            f"    {name:<28} {_num(c.estimate)} [{_num(c.ci_low)}, "
            f"{_num(c.ci_high)}], p = {fmt_p(c.p if math.isfinite(c.p) else None)}"
        )
    return lines


def _num(value: float) -> str:
    return fmt(value, 3) if math.isfinite(value) else "undefined"
