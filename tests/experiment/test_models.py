"""The models against independent fits: statsmodels on explicit design matrices (no
formulas), statsmodels' own Wald tests, and the repeated-measures ANOVA."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pandas as pd
import pytest
import statsmodels.api as sm
from statsmodels.stats.anova import AnovaRM

from chameleons.experiment.stats import AnalysisError, analyze, render_text
from chameleons.experiment.stats.models import fit_models

CONDITIONS = ["natural", "copy", "still"]


def simulated(n: int = 30, seed: int = 0) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Score rows (participant x condition, with position) and suggestion rows."""
    rng = np.random.default_rng(seed)
    scores, suggestions = [], []
    for p in range(n):
        level, tendency = rng.normal(0, 1.0), rng.normal(0, 0.8)
        order = rng.permutation(CONDITIONS)
        for position, condition in enumerate(order, start=1):
            item_set = "better" if (p + position) % 2 else "worse"
            accepted = 0
            for index in range(3):
                kind = "random" if rng.random() < 0.15 else "optimal"
                logit = tendency + 0.8 * (condition == "copy") - 0.3 * (item_set == "worse")
                decision = bool(rng.random() < 1 / (1 + np.exp(-logit)))
                accepted += decision
                suggestions.append(
                    {
                        "participant": f"P{p:03d}",
                        "session": str(p + 1),
                        "position": str(position),
                        "condition": str(condition),
                        "item_set": item_set,
                        "kind": kind,
                        "accepted": "true" if decision else "false",
                        "index": index + 1,
                    }
                )
            shift = 0.6 * (condition == "copy") + 0.2 * position
            scores.append(
                {
                    "participant": f"P{p:03d}",
                    "condition": str(condition),
                    "position": position,
                    "accepted": accepted,
                    "trust": round(4.5 + level + shift + rng.normal(0, 0.6), 4),
                }
            )
    return scores, suggestions


def dummies(frame: pd.DataFrame, column: str, reference: str) -> pd.DataFrame:
    levels = sorted(set(frame[column].astype(str)) - {reference})
    return pd.DataFrame(
        {
            f"{column}={level}": (frame[column].astype(str) == level).astype(float)
            for level in levels
        }
    )


@pytest.mark.parametrize("by_kind", [False, True])
def test_acceptance_model_equals_an_independent_gee_fit(by_kind: bool) -> None:
    """The primary model (the condition's total effect) has no kind term; the secondary
    one adds it. Both equal a GEE on explicit design matrices."""
    scores, suggestions = simulated()
    models = fit_models(scores, suggestions, measures=["accepted"], conditions=CONDITIONS,
                        reference="still")  # fmt: skip
    acceptance = models.acceptance_by_kind if by_kind else models.acceptance
    assert acceptance is not None
    assert acceptance.error is None
    frame = pd.DataFrame(suggestions)
    exog = pd.concat(
        [
            pd.Series(1.0, index=frame.index, name="const"),
            dummies(frame, "condition", "still"),
            dummies(frame, "position", "1"),
            dummies(frame, "item_set", "better"),
            *([dummies(frame, "kind", "optimal")] if by_kind else []),
        ],
        axis=1,
    )
    endog = (frame["accepted"] == "true").astype(float)
    independent = sm.GEE(
        endog,
        exog,
        groups=frame["participant"],
        family=sm.families.Binomial(),
        cov_struct=sm.cov_struct.Exchangeable(),
    ).fit(cov_type="bias_reduced")
    expected = dict(zip(exog.columns, independent.params, strict=True))
    errors = dict(zip(exog.columns, independent.bse, strict=True))
    for c in acceptance.coefficients:
        name = "const" if c.term == "Intercept" else f"{c.term}={c.level}"
        assert c.estimate == pytest.approx(expected[name], rel=1e-6, abs=1e-9)
        assert c.se == pytest.approx(errors[name], rel=1e-6)
        if c.odds_ratio is not None:
            assert c.odds_ratio == pytest.approx(np.exp(expected[name]), rel=1e-6)
    # The joint test of condition: statsmodels' own Wald test on the same coefficients.
    wald = independent.wald_test("condition=copy = 0, condition=natural = 0", scalar=True)
    test = acceptance.test("condition")
    assert test is not None
    assert test.df == 2
    assert test.chi2 == pytest.approx(float(wald.statistic), rel=1e-6)
    assert test.p == pytest.approx(float(wald.pvalue), rel=1e-6)
    assert acceptance.reference == {
        "condition": "still", "position": "1", "item_set": "better",
        **({"kind": "optimal"} if by_kind else {}),
    }  # fmt: skip
    assert acceptance.n_observations == len(suggestions)
    assert acceptance.n_participants == 30
    assert ("C(kind)" in acceptance.formula) == by_kind
    assert ("mediator" in " ".join(acceptance.notes)) == by_kind
    assert [m.name for m in models.fitted] == ["acceptance", "acceptance_by_kind"]


def test_the_default_acceptance_model_is_the_total_effect() -> None:
    """Kind depends on earlier acceptances, so the primary model must not adjust for it; the
    text report names the kind-adjusted model as a secondary adjusted for a mediator."""
    scores, suggestions = simulated()
    analysis = analyze(scores, measures=["accepted", "trust"], models=True,
                       suggestions=suggestions)  # fmt: skip
    assert analysis.models is not None
    assert analysis.models.acceptance is not None
    assert analysis.models.acceptance.formula == (
        "accepted ~ C(condition) + C(position) + C(item_set)"
    )
    data = json.loads(json.dumps(analysis.to_dict()))
    assert "C(kind)" in data["models"]["acceptance_by_kind"]["formula"]
    text = render_text(analysis)
    primary = text.index("acceptance (total effect of condition): accepted ~ C(condition)")
    secondary = text.index("acceptance adjusted for suggestion kind (secondary: kind is")
    assert primary < secondary


def test_score_model_equals_an_independent_mixed_model_fit() -> None:
    scores, _ = simulated(seed=4)
    model = fit_models(scores, None, measures=["accepted", "trust"], conditions=CONDITIONS,
                       reference="still").scores["trust"]  # fmt: skip
    assert model.error is None
    frame = pd.DataFrame(scores)
    exog = pd.concat(
        [
            pd.Series(1.0, index=frame.index, name="const"),
            dummies(frame, "condition", "still"),
            dummies(frame, "position", "1"),
        ],
        axis=1,
    )
    independent = sm.MixedLM(frame["trust"], exog, groups=frame["participant"]).fit(reml=True)
    for c, name in zip(model.coefficients, exog.columns, strict=True):
        assert c.estimate == pytest.approx(independent.fe_params[name], rel=1e-4, abs=1e-6)
        assert c.se == pytest.approx(independent.bse_fe[name], rel=1e-3)
    assert model.variance["residual"] == pytest.approx(independent.scale, rel=1e-3)
    copy = next(c for c in model.coefficients if c.level == "copy")
    assert copy.ci_low < 0.6 < copy.ci_high  # the simulated effect is inside its interval


def test_condition_test_equals_the_repeated_measures_anova() -> None:
    """Balanced complete data, condition only: the REML Wald chi2 / df is the RM-ANOVA F."""
    scores, _ = simulated(n=24, seed=8)
    rows = [{k: v for k, v in row.items() if k != "position"} for row in scores]
    model = fit_models(rows, None, measures=["trust"], conditions=CONDITIONS).scores["trust"]
    assert any("no position column" in note for note in model.notes)
    anova = AnovaRM(pd.DataFrame(rows), "trust", "participant", within=["condition"]).fit()
    f_value = float(anova.anova_table.loc["condition", "F Value"])
    test = model.test("condition")
    assert test is not None
    assert test.chi2 / test.df == pytest.approx(f_value, rel=1e-4)
    assert test.f == pytest.approx(f_value, rel=1e-4)
    assert test.df_denominator == int(anova.anova_table.loc["condition", "Den DF"])
    assert test.p_f == pytest.approx(float(anova.anova_table.loc["condition", "Pr > F"]), rel=1e-3)


def test_models_that_cannot_be_fitted_say_why() -> None:
    scores, suggestions = simulated(n=6)
    everyone_accepts = [{**s, "accepted": "true"} for s in suggestions]
    models = fit_models(scores, everyone_accepts, measures=["accepted", "trust"],
                        conditions=CONDITIONS)  # fmt: skip
    assert models.acceptance is not None
    assert "same outcome" in (models.acceptance.error or "")
    one_condition = [s for s in scores if s["condition"] == "copy"]
    only = fit_models(one_condition, None, measures=["trust"], conditions=["copy"])
    assert "at least two conditions" in (only.scores["trust"].error or "")
    assert "per-suggestion rows" in only.notes[0]
    same_order = [{**row, "position": CONDITIONS.index(row["condition"]) + 1} for row in scores]
    confounded = fit_models(same_order, None, measures=["trust"], conditions=CONDITIONS)
    assert "confounded" in (confounded.scores["trust"].error or "")


def test_bad_values_are_refused_readably() -> None:
    scores, suggestions = simulated(n=4)
    suggestions[3]["accepted"] = "perhaps"
    with pytest.raises(AnalysisError, match="accepted: 'perhaps' is not true/false"):
        analyze(scores, models=True, suggestions=suggestions)
    scores[2]["position"] = "second"
    with pytest.raises(AnalysisError, match="position: 'second' is not a number"):
        analyze(scores, models=True)


def test_analysis_json_has_models_without_nan() -> None:
    scores, suggestions = simulated(n=12, seed=2)
    data = json.loads(
        json.dumps(analyze(scores, models=True, suggestions=suggestions).to_dict(), allow_nan=False)
    )
    assert data["models"]["reference"]["condition"] == "still"
    assert data["models"]["acceptance"]["formula"].startswith("accepted ~ C(condition)")
    assert "logistic regression" in data["models"]["acceptance"]["description"]
    trust = data["models"]["scores"]["trust"]
    assert [t["term"] for t in trust["tests"]] == ["condition", "position"]
    assert trust["formula"] == "trust ~ C(condition) + C(position) + (1 | participant)"
    assert analyze(scores).to_dict()["models"] is None


def test_models_follow_the_views_participants_and_conditions() -> None:
    """Excluded participants leave the models; as planned, a deviating interaction counts
    for its planned condition; as run, the deviating participant leaves."""
    scores, suggestions = simulated(n=12, seed=6)
    for row in scores:
        row["planned_condition"] = row["condition"]
        row["excluded"] = row["participant"] == "P000"
    swapped = {"P001": {"copy": "still", "still": "copy"}}
    for row in [*scores, *suggestions]:
        row["planned_condition"] = row["condition"]
        row["condition"] = swapped.get(row["participant"], {}).get(
            row["condition"], row["condition"]
        )
    planned = analyze(scores, models=True, suggestions=suggestions)
    run = analyze(scores, models=True, suggestions=suggestions, view="as_run")
    assert planned.models is not None
    assert run.models is not None
    assert planned.models.acceptance is not None
    assert run.models.acceptance is not None
    assert planned.models.acceptance.n_participants == 11  # P000 excluded
    assert run.models.acceptance.n_participants == 10  # and P001 deviated
    assert planned.models.scores["trust"].n_participants == 11
    # As planned, P001's interactions count for the planned conditions: the same model as
    # data in which the swap never happened.
    unswapped = [{**row, "condition": row["planned_condition"]} for row in suggestions]
    plain = analyze(scores, models=True, suggestions=unswapped)
    assert plain.models is not None
    assert plain.models.acceptance is not None
    assert plain.models.acceptance.coefficients == planned.models.acceptance.coefficients
