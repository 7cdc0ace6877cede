"""Regression models beyond the rank tests (statsmodels).

- **Acceptance** of each robot suggestion (yes/no): logistic regression on condition,
  interaction position and item set, fitted by generalized estimating equations (GEE) with
  an exchangeable working correlation among one participant's suggestions. Standard errors
  are the bias-reduced sandwich of Mancl & DeRouen (2001), because a study has few
  participants (clusters) and the plain sandwich is then too small. Estimates are
  population-averaged log-odds (reported with odds ratios). This is the condition's *total*
  effect: the suggestion kind (optimal or random fallback) is left out because it is a
  consequence of the participant's earlier decisions (a participant who accepts reaches
  the expert order sooner and then gets random suggestions), so adjusting for it would
  condition on a mediator. The kind-adjusted model is fitted as a labelled secondary
  (``acceptance_by_kind``).
- **Questionnaire scores** (one per interaction): a linear mixed model with a random
  intercept per participant and condition + position as fixed effects, fitted by REML.

Every model reports its coefficients with 95% Wald intervals and z tests, a joint Wald
test per term (condition: k - 1 degrees of freedom), the sample it used, the formula and
the model in words. A model that cannot be fitted (one condition only, no variation, a
numerical failure) gives a readable error instead of numbers; statsmodels' warnings
(convergence, boundary) become notes.

This module builds the models (factors, reference levels, words); the data frames are
:mod:`.model_frames`'s, the fitting :mod:`.model_estimates`'s, the result types
:mod:`.model_results`'s (all re-exported here).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from chameleons.experiment.stats.model_estimates import fit_model
from chameleons.experiment.stats.model_frames import categorical, score_frame, suggestion_frame
from chameleons.experiment.stats.model_results import (
    Coefficient,
    ModelInputError,
    ModelResult,
    Models,
    TermTest,
)

if TYPE_CHECKING:  # pandas is imported where it is used: the CLI starts faster
    import pandas as pd

__all__ = [
    "Coefficient",
    "ModelInputError",
    "ModelResult",
    "Models",
    "TermTest",
    "fit_acceptance",
    "fit_models",
    "fit_score",
    "score_frame",
    "suggestion_frame",
]

FACTOR_WORDS = {
    "condition": "condition",
    "position": "interaction position",
    "item_set": "item set",
    "kind": "suggestion kind",
}
TOTAL_FACTORS = ["condition", "position", "item_set"]
MEDIATOR_NOTE = (
    "secondary: adjusted for the suggestion kind, which depends on the participant's earlier "
    "decisions (a mediator), so its condition effect is not the total effect; the primary "
    "acceptance model leaves the kind out"
)


def fit_models(
    score_rows: Iterable[Mapping[str, Any]],
    suggestion_rows: Iterable[Mapping[str, Any]] | None,
    *,
    measures: Sequence[str],
    conditions: Sequence[str],
    reference: str | None = None,
) -> Models:
    """The acceptance model (when suggestion rows are given) and a score model per
    questionnaire measure (every measure but ``accepted``). ``reference``: the condition
    the others are compared with (default: the first of ``conditions``)."""
    baseline = reference if reference is not None and reference in conditions else conditions[0]
    scores = score_frame(score_rows, [m for m in measures if m != "accepted"])
    notes: list[str] = []
    acceptance = by_kind = None
    if suggestion_rows is None:
        notes.append("acceptance model not fitted: it needs the per-suggestion rows")
    else:
        frame = suggestion_frame(suggestion_rows)
        acceptance = fit_acceptance(frame, conditions, baseline)
        by_kind = fit_acceptance(frame, conditions, baseline, adjust_for_kind=True)
    fitted = {m: fit_score(scores, m, conditions, baseline) for m in measures if m != "accepted"}
    references = {"condition": baseline, "position": "1"}
    for model in (acceptance, by_kind):
        if model is not None:
            references.update(model.reference)
    return Models(references, acceptance, fitted, notes, by_kind)


def fit_acceptance(
    frame: pd.DataFrame,
    conditions: Sequence[str],
    reference: str,
    *,
    adjust_for_kind: bool = False,
) -> ModelResult:
    """The condition's total effect on acceptance; ``adjust_for_kind``: the secondary model
    with the suggestion kind (a mediator) as a factor too."""
    result = ModelResult(
        name="acceptance_by_kind" if adjust_for_kind else "acceptance",
        outcome="accepted",
        family="binomial (logit link)",
        method="GEE, exchangeable working correlation within participant, "
        "bias-reduced sandwich standard errors (Mancl & DeRouen 2001)",
        formula="",
        description="",
        reference={},
    )
    decided = frame[frame["accepted"].notna()].copy()
    undecided = len(frame) - len(decided)
    if undecided:
        result.notes.append(f"{undecided} suggestion(s) without a decision left out")
    wanted = [*TOTAL_FACTORS, "kind"] if adjust_for_kind else TOTAL_FACTORS
    factors = _usable_factors(decided, wanted, result)
    if adjust_for_kind:
        result.notes.insert(0, MEDIATOR_NOTE)
    if "condition" not in factors:
        result.error = "needs suggestions in at least two conditions"
        return result
    firsts = {"condition": reference, "position": "1", "item_set": None, "kind": "optimal"}
    for name in factors:
        decided[name] = categorical(decided[name], firsts.get(name))
        result.reference[name] = str(decided[name].cat.categories[0])
    result.formula = "accepted ~ " + " + ".join(f"C({f})" for f in factors)
    result.description = _words_acceptance(factors, result.reference, adjust_for_kind)
    result.n_observations, result.n_participants = len(decided), decided["participant"].nunique()
    if decided["accepted"].nunique() < 2:
        result.error = "every decided suggestion has the same outcome: nothing to model"
        return result
    fit_model(result, decided, factors, binomial=True)
    return result


def fit_score(
    frame: pd.DataFrame, measure: str, conditions: Sequence[str], reference: str
) -> ModelResult:
    result = ModelResult(
        name=measure,
        outcome=measure,
        family="gaussian",
        method="linear mixed model, random intercept per participant, REML",
        formula=f"{measure} ~ C(condition) + C(position) + (1 | participant)",
        description="",
        reference={},
    )
    if measure not in frame:
        result.error = f"no {measure} column"
        return result
    data = frame[frame[measure].notna()].copy()
    factors = _usable_factors(data, ["condition", "position"], result)
    if "condition" not in factors:
        result.error = "needs scores in at least two conditions"
        return result
    firsts = {"condition": reference, "position": "1"}
    for name in factors:
        data[name] = categorical(data[name], firsts[name])
        result.reference[name] = str(data[name].cat.categories[0])
    result.formula = f"{measure} ~ " + " + ".join(f"C({f})" for f in factors)
    result.formula += " + (1 | participant)"
    result.description = _words_score(measure, factors, result.reference)
    result.n_observations, result.n_participants = len(data), data["participant"].nunique()
    if result.n_participants < 2:
        result.error = "needs at least two participants"
        return result
    fit_model(result, data.rename(columns={measure: "outcome_value"}), factors, binomial=False)
    return result


def _usable_factors(frame: pd.DataFrame, names: list[str], result: ModelResult) -> list[str]:
    usable = []
    for name in names:
        if name not in frame:
            result.notes.append(f"{FACTOR_WORDS[name]} left out: no {name} column")
            continue
        if frame[name].isna().any():
            result.notes.append(f"{FACTOR_WORDS[name]} left out: missing values")
        elif frame[name].astype(str).nunique() >= 2:
            usable.append(name)
        elif len(frame):
            result.notes.append(f"{FACTOR_WORDS[name]} left out: only one level in the data")
    return usable


def _words_acceptance(factors: list[str], reference: Mapping[str, str], by_kind: bool) -> str:
    why = (
        " Secondary analysis: the suggestion kind is a consequence of the participant's "
        "earlier decisions (a mediator), so the condition's odds ratio here is conditional "
        "on it and is not the condition's total effect."
        if by_kind
        else " The suggestion kind is left out on purpose: whether a suggestion is optimal "
        "or a random fallback depends on the participant's earlier decisions, so the "
        "condition's odds ratio is its total effect."
    )
    return (
        "Whether the participant accepted each robot suggestion, modelled with logistic "
        "regression on "
        + _factor_list(factors, reference)
        + ". Suggestions of one participant are correlated (exchangeable correlation, "
        "generalized estimating equations), so the odds ratios are population-averaged: "
        "an odds ratio above 1 means the suggestions were accepted more often than in the "
        "reference level, averaged over participants." + why
    )


def _words_score(measure: str, factors: list[str], reference: Mapping[str, str]) -> str:
    return (
        f"The {measure} score of each interaction, modelled as a linear mixed model on "
        + _factor_list(factors, reference)
        + ", with a random intercept per participant (each participant has their own "
        "overall level). A coefficient is the difference in scale points from the "
        "reference level for the same participant."
    )


def _factor_list(factors: list[str], reference: Mapping[str, str]) -> str:
    parts = [f"{FACTOR_WORDS[f]} (reference: {reference[f]})" for f in factors]
    return ", ".join(parts[:-1]) + (" and " if len(parts) > 1 else "") + parts[-1]
