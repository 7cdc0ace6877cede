"""Synchrony in the analysis: by condition, mimicry as an outcome and as a covariate, on
rows with a known structure (and statsmodels' own fit of the same frame as the check)."""

from __future__ import annotations

import math
import random
from typing import Any

import pytest

from chameleons.experiment.stats.synchrony.outcomes import analyze_synchrony, coefficient

CONDITIONS = ("natural", "copy", "still")
ORDERS = [
    ("natural", "copy", "still"), ("copy", "still", "natural"), ("still", "natural", "copy"),
    ("still", "copy", "natural"), ("natural", "still", "copy"), ("copy", "natural", "still"),
]  # fmt: skip
MIMICRY = {"natural": 0.05, "copy": 0.25, "still": 0.0}  # mean mimicry_z by condition
SLOPE = 1.5  # credibility points per unit of mimicry_z


def rows(
    participants: int = 24, seed: int = 3
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    rng = random.Random(seed)
    interactions, scores = [], []
    for number in range(participants):
        code = f"P{number + 1:03d}"
        level, own = rng.gauss(0, 0.5), rng.gauss(0, 0.05)
        for position, condition in enumerate(ORDERS[number % 6], 1):
            z = MIMICRY[condition] + own + rng.gauss(0, 0.15)
            still = condition == "still"
            interactions.append({
                "participant": code, "session": number + 1, "position": float(position),
                "planned_condition": condition, "condition": condition, "deviation": False,
                "sync_r": "" if still else round(0.9 if condition == "copy" else 0.2, 4),
                "sync_lag_s": "" if still else (4.0 if condition == "copy" else 1.2),
                "sync_check": "ok" if condition == "copy" else "",
                "sync_missing": "robot_still" if still else "",
                "mimicry_r": "" if still else round(math.tanh(z), 6),
                "mimicry_lag_s": "" if still else 1.0,
            })  # fmt: skip
            scores.append({
                "participant": code, "condition": condition, "position": position,
                "credibility": 4.0 + level + SLOPE * z + rng.gauss(0, 0.05), "excluded": False,
            })  # fmt: skip
    return interactions, scores


def test_by_condition_counts_values_checks_and_reasons() -> None:
    interactions, scores = rows()
    result = analyze_synchrony(interactions, scores, conditions=CONDITIONS, models=False)
    assert result is not None
    summary = {c.condition: c for c in result.conditions}
    assert summary["copy"].sync_lag_s.median == 4.0
    assert summary["copy"].checks == {"ok": 24}
    assert summary["still"].missing == {"robot_still": 24}
    assert summary["still"].mimicry_r.n == 0
    assert summary["copy"].mimicry_r.mean is not None
    assert summary["natural"].mimicry_r.mean is not None
    assert summary["copy"].mimicry_r.mean > summary["natural"].mimicry_r.mean


def test_mimicry_as_outcome_finds_the_condition_difference() -> None:
    interactions, scores = rows()
    result = analyze_synchrony(interactions, scores, conditions=CONDITIONS, reference="natural",
                               measures=("credibility",))  # fmt: skip
    assert result is not None
    model = result.mimicry_model
    assert model is not None
    assert model.error is None
    copy = coefficient(model, "condition", "copy")
    assert copy is not None
    assert copy.estimate == pytest.approx(0.20, abs=0.08)
    assert copy.p < 0.001
    assert model.n_observations == 48  # still has no mimicry: nothing moved
    assert {c.level for c in model.coefficients if c.term == "position"} == {"2", "3"}


def test_mimicry_as_covariate_recovers_the_slope_and_matches_statsmodels() -> None:
    import pandas as pd
    import statsmodels.formula.api as smf

    interactions, scores = rows()
    result = analyze_synchrony(interactions, scores, conditions=CONDITIONS, reference="natural",
                               measures=("accepted", "credibility"))  # fmt: skip
    assert result is not None
    assert set(result.covariate_models) == {"credibility"}  # accepted is not a score
    model = result.covariate_models["credibility"]
    assert model.error is None
    slope = coefficient(model, "mimicry_z")
    assert slope is not None
    assert slope.estimate == pytest.approx(SLOPE, abs=0.15)
    frame = pd.DataFrame([
        {"participant": i["participant"], "condition": i["condition"], "position": i["position"],
         "mimicry_z": math.atanh(float(i["mimicry_r"])), "credibility": s["credibility"]}
        for i, s in zip(interactions, scores, strict=True) if i["mimicry_r"] != ""
    ])  # fmt: skip
    frame["condition"] = pd.Categorical(frame["condition"], ["natural", "copy"])
    frame["position"] = pd.Categorical(frame["position"].astype(int).astype(str), ["1", "2", "3"])
    direct = smf.mixedlm("credibility ~ C(condition) + C(position) + mimicry_z", frame,
                         groups=frame["participant"]).fit(reml=True)  # fmt: skip
    assert slope.estimate == pytest.approx(float(direct.params["mimicry_z"]), abs=1e-6)


def test_excluded_participants_and_the_as_run_view() -> None:
    interactions, scores = rows(participants=12)
    for score in scores:
        if score["participant"] == "P001":
            score["excluded"] = True
    interactions[3] = {**interactions[3], "condition": "natural", "deviation": True}
    result = analyze_synchrony(interactions, scores, conditions=CONDITIONS, view="as_run",
                               models=False)  # fmt: skip
    assert result is not None
    assert result.participants == 10
    assert "1 excluded participant(s) left out" in result.notes


def test_rows_without_synchrony_columns_give_none() -> None:
    assert analyze_synchrony([{"participant": "P001", "condition": "copy"}], [],
                             conditions=CONDITIONS) is None  # fmt: skip
