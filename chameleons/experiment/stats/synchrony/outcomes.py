"""Synchrony in the analysis (issue 32): by condition, and the participant's mimicry of
the robot as an outcome and as a covariate, from the export's interaction rows.

- **By condition**: the robot following the participant (``sync_r``, ``sync_lag_s``: the
  manipulation's fidelity; a copy condition should show its delay), the participant's
  mimicry (``mimicry_r``, surrogate-corrected), the copy checks, and why values are
  missing.
- **Mimicry as an outcome**: a linear mixed model of ``mimicry_z = atanh(mimicry_r)`` (the
  surrogate-corrected Fisher z, the scale the correction was made on) on condition and
  position with a random intercept per participant (the score models' form,
  :func:`fit_score`).
- **Mimicry as a covariate**: each questionnaire score on condition, position and the
  interaction's ``mimicry_z``, random intercept per participant: does a participant who
  mimicked the robot more rate it differently, over and above the condition?

Rows are dicts with the export's column names (``interactions.csv``, ``scores.csv``); the
view and exclusions follow the main analysis: excluded participants leave, ``as_planned``
counts each interaction for its planned condition, ``as_run`` leaves out participants with
a deviation.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

from chameleons.experiment.stats.descriptive import Descriptive, describe
from chameleons.experiment.stats.models import Coefficient, ModelResult, fit_score
from chameleons.experiment.stats.synchrony.covariate import fit_with_covariate

Row = Mapping[str, Any]
OUTCOME = "mimicry_z"


@dataclass
class ConditionSynchrony:
    condition: str
    interactions: int
    sync_r: Descriptive
    sync_lag_s: Descriptive
    mimicry_r: Descriptive
    mimicry_lag_s: Descriptive
    checks: dict[str, int] = field(default_factory=dict)  # ok / failed
    missing: dict[str, int] = field(default_factory=dict)  # reason -> interactions

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        for name in ("sync_r", "sync_lag_s", "mimicry_r", "mimicry_lag_s"):
            data[name] = getattr(self, name).to_dict()
        return data


@dataclass
class SynchronyAnalysis:
    view: str
    conditions: list[ConditionSynchrony]
    mimicry_model: ModelResult | None
    covariate_models: dict[str, ModelResult]
    participants: int
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "view": self.view,
            "participants": self.participants,
            "conditions": [c.to_dict() for c in self.conditions],
            "mimicry_model": None if self.mimicry_model is None else self.mimicry_model.to_dict(),
            "covariate_models": {m: r.to_dict() for m, r in self.covariate_models.items()},
            "notes": self.notes,
        }


def analyze_synchrony(
    interactions: Iterable[Row],
    scores: Iterable[Row] = (),
    *,
    conditions: Sequence[str],
    measures: Sequence[str] = (),
    reference: str | None = None,
    view: str = "as_planned",
    models: bool = True,
) -> SynchronyAnalysis | None:
    """None when the rows carry no synchrony columns (an export from before issue 32)."""
    rows = [dict(r) for r in interactions]
    if not rows or "mimicry_r" not in rows[0]:
        return None
    score_rows = [dict(r) for r in scores]
    excluded = {str(r["participant"]) for r in score_rows if _true(r.get("excluded"))}
    notes = []
    if excluded:
        notes.append(f"{len(excluded)} excluded participant(s) left out")
    rows = [r for r in rows if str(r["participant"]) not in excluded]
    if view == "as_run":
        deviating = {str(r["participant"]) for r in rows if _true(r.get("deviation"))}
        if deviating:
            notes.append(f"as run: {len(deviating)} participant(s) with a deviation left out")
        rows = [r for r in rows if str(r["participant"]) not in deviating]
    else:
        rows = [{**r, "condition": r.get("planned_condition") or r["condition"]} for r in rows]
    baseline = reference if reference is not None and reference in conditions else conditions[0]
    summary = [_condition(c, [r for r in rows if r["condition"] == c]) for c in conditions]
    result = SynchronyAnalysis(view, summary, None, {},
                               len({str(r["participant"]) for r in rows}), notes)  # fmt: skip
    if models:
        frame = _mimicry_frame(rows)
        result.mimicry_model = _outcome_model(frame, conditions, baseline)
        for measure in (m for m in measures if m != "accepted"):
            joined = _with_scores(frame, score_rows, measure, view)
            result.covariate_models[measure] = fit_with_covariate(
                joined, measure, OUTCOME, conditions, baseline
            )
    return result


def _condition(condition: str, rows: list[dict[str, Any]]) -> ConditionSynchrony:
    def values(column: str) -> list[float]:
        return [v for r in rows if (v := _number(r.get(column))) is not None]

    checks = Counter(str(r["sync_check"]) for r in rows if r.get("sync_check"))
    missing = Counter(str(r["sync_missing"]) for r in rows if r.get("sync_missing"))
    return ConditionSynchrony(
        condition, len(rows), describe(values("sync_r")), describe(values("sync_lag_s")),
        describe(values("mimicry_r")), describe(values("mimicry_lag_s")), dict(checks),
        dict(missing),
    )  # fmt: skip


def _mimicry_frame(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    frame = []
    for r in rows:
        value = _number(r.get("mimicry_r"))
        if value is None or abs(value) >= 1:
            continue
        frame.append({
            "participant": str(r["participant"]), "condition": str(r["condition"]),
            "position": _position(r.get("position")), OUTCOME: math.atanh(value),
        })  # fmt: skip
    return frame


def _outcome_model(frame: list[dict[str, Any]], conditions: Sequence[str],
                   reference: str) -> ModelResult:  # fmt: skip
    import pandas as pd

    data = pd.DataFrame(frame, columns=["participant", "condition", "position", OUTCOME])
    result = fit_score(data, OUTCOME, conditions, reference)
    result.description = (
        "The participant's mimicry of the robot (mimicry_z = atanh(mimicry_r), the "
        "surrogate-corrected Fisher z of the peak where the participant follows the robot), "
        "modelled as a linear mixed model on condition and position with a random intercept "
        "per participant. A coefficient is the difference in z from the reference condition "
        "for the same participant."
    )
    return result


def _with_scores(frame: list[dict[str, Any]], scores: list[dict[str, Any]], measure: str,
                 view: str) -> list[dict[str, Any]]:  # fmt: skip
    """The score of each interaction (participant, position) beside its mimicry."""
    by_slot = {(str(s["participant"]), _position(s.get("position"))): s for s in scores}
    joined = []
    for row in frame:
        score = by_slot.get((row["participant"], row["position"]))
        value = _number(score.get(measure)) if score is not None else None
        if value is not None:
            joined.append({**row, measure: value})
    return joined


def _number(value: Any) -> float | None:
    if value is None or (isinstance(value, str) and value.strip() == ""):
        return None
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def _position(value: Any) -> int | None:
    """An interaction position as a whole number (a CSV gives "2", a frame 2.0)."""
    number = _number(value)
    return None if number is None else int(number)


def _true(value: Any) -> bool:
    return value is True or str(value).strip().lower() in {"true", "1", "yes"}


def coefficient(model: ModelResult, term: str, level: str = "") -> Coefficient | None:
    return next((c for c in model.coefficients if c.term == term and c.level == level), None)
