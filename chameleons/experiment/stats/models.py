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
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.stats import chi2 as chi2_distribution
from scipy.stats import f as f_distribution
from scipy.stats import norm

if TYPE_CHECKING:  # pandas is imported where it is used: the CLI starts faster
    import pandas as pd

Z95 = float(norm.ppf(0.975))
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


class ModelInputError(ValueError):
    """Rows a model cannot use (a missing column, a value that is not a number)."""


@dataclass(frozen=True)
class Coefficient:
    term: str  # "Intercept" or a factor name
    level: str  # the level compared with the reference ("" for the intercept)
    estimate: float
    se: float
    z: float
    p: float
    ci_low: float
    ci_high: float
    odds_ratio: float | None = None  # binomial models: exp(estimate) and its interval
    or_ci_low: float | None = None
    or_ci_high: float | None = None


@dataclass(frozen=True)
class TermTest:
    """Joint Wald test of a factor; for the mixed models also as an F test with the
    within-participant residual degrees of freedom (exact for complete balanced data)."""

    term: str
    chi2: float
    df: int
    p: float
    f: float | None = None
    df_denominator: int | None = None
    p_f: float | None = None


@dataclass
class ModelResult:
    name: str
    outcome: str
    family: str
    method: str
    formula: str
    description: str
    reference: dict[str, str]
    n_observations: int = 0
    n_participants: int = 0
    coefficients: list[Coefficient] = field(default_factory=list)
    tests: list[TermTest] = field(default_factory=list)
    variance: dict[str, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    error: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def test(self, term: str) -> TermTest | None:
        return next((t for t in self.tests if t.term == term), None)


@dataclass
class Models:
    reference: dict[str, str]
    acceptance: ModelResult | None  # primary: the condition's total effect (no kind)
    scores: dict[str, ModelResult]
    notes: list[str] = field(default_factory=list)
    acceptance_by_kind: ModelResult | None = None  # secondary: adjusted for the mediator

    @property
    def fitted(self) -> list[ModelResult]:
        """Every model, in the order they are reported (primary acceptance first)."""
        acceptance = [m for m in (self.acceptance, self.acceptance_by_kind) if m is not None]
        return [*acceptance, *self.scores.values()]

    def to_dict(self) -> dict[str, Any]:
        return {
            "reference": self.reference,
            "acceptance": None if self.acceptance is None else self.acceptance.to_dict(),
            "acceptance_by_kind": None
            if self.acceptance_by_kind is None
            else self.acceptance_by_kind.to_dict(),
            "scores": {m: r.to_dict() for m, r in self.scores.items()},
            "notes": self.notes,
        }


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


def score_frame(rows: Iterable[Mapping[str, Any]], measures: Sequence[str]) -> pd.DataFrame:
    import pandas as pd

    frame = pd.DataFrame(list(rows))
    _require(frame, ["participant", "condition"], "scores")
    frame["participant"] = frame["participant"].astype(str)
    frame["condition"] = frame["condition"].astype(str)
    if "position" in frame:  # older score files have none: the models then leave it out
        frame["position"] = _numbers(frame["position"], "position").astype("Int64")
    for measure in measures:
        if measure in frame:
            frame[measure] = _numbers(frame[measure], measure)
    return frame


def suggestion_frame(rows: Iterable[Mapping[str, Any]]) -> pd.DataFrame:
    """Per-suggestion rows: participant, condition, position, item_set, kind, accepted
    (true/false, empty when never decided)."""
    import pandas as pd

    frame = pd.DataFrame(list(rows))
    _require(frame, ["participant", "condition", "position", "item_set", "kind", "accepted"],
             "suggestions")  # fmt: skip
    frame["participant"] = frame["participant"].astype(str)
    frame["position"] = _numbers(frame["position"], "position").astype("Int64")
    frame["accepted"] = frame["accepted"].map(_decision)
    return frame


def _require(frame: pd.DataFrame, columns: list[str], table: str) -> None:
    import pandas as pd

    missing = [c for c in columns if c not in frame.columns]
    if missing and len(frame):
        raise ModelInputError(f"{table}: missing column(s) {', '.join(missing)}")
    for column in missing:
        frame[column] = pd.Series(dtype=object)


def _numbers(column: pd.Series, name: str) -> pd.Series:
    import pandas as pd

    text = column.map(lambda v: None if v is None or str(v).strip() == "" else v)
    converted = pd.to_numeric(text, errors="coerce")
    bad = converted.isna() & text.notna()
    if bad.any():
        raise ModelInputError(f"{name}: {text[bad].iloc[0]!r} is not a number")
    return converted.astype("float64")


def _decision(value: object) -> float | None:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return None
    if isinstance(value, bool):
        return float(value)
    text = str(value).strip().lower()
    if text in {"true", "1", "yes", "1.0"}:
        return 1.0
    if text in {"false", "0", "no", "0.0"}:
        return 0.0
    if text in {"", "na", "nan", "none", "null"}:
        return None
    raise ModelInputError(f"accepted: {value!r} is not true/false")


def _categorical(series: pd.Series, first: str | None = None) -> pd.Series:
    """A categorical whose first category (the model's reference) is ``first``."""
    import pandas as pd

    levels = sorted({str(v) for v in series}, key=_level_key)
    if first is not None and first in levels:
        levels.remove(first)
        levels.insert(0, first)
    return pd.Series(pd.Categorical(series.astype(str), categories=levels), index=series.index)


def _level_key(level: str) -> tuple[int, float | str]:
    try:
        return (0, float(level))
    except ValueError:
        return (1, level)


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
        decided[name] = _categorical(decided[name], firsts.get(name))
        result.reference[name] = str(decided[name].cat.categories[0])
    result.formula = "accepted ~ " + " + ".join(f"C({f})" for f in factors)
    result.description = _words_acceptance(factors, result.reference, adjust_for_kind)
    result.n_observations, result.n_participants = len(decided), decided["participant"].nunique()
    if decided["accepted"].nunique() < 2:
        result.error = "every decided suggestion has the same outcome: nothing to model"
        return result
    _fit(result, decided, factors, binomial=True)
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
        data[name] = _categorical(data[name], firsts[name])
        result.reference[name] = str(data[name].cat.categories[0])
    result.formula = f"{measure} ~ " + " + ".join(f"C({f})" for f in factors)
    result.formula += " + (1 | participant)"
    result.description = _words_score(measure, factors, result.reference)
    result.n_observations, result.n_participants = len(data), data["participant"].nunique()
    if result.n_participants < 2:
        result.error = "needs at least two participants"
        return result
    _fit(result, data.rename(columns={measure: "outcome_value"}), factors, binomial=False)
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


def _fit(result: ModelResult, data: pd.DataFrame, factors: list[str], *, binomial: bool) -> None:
    import statsmodels.api as sm
    import statsmodels.formula.api as smf

    right = " + ".join(f"C({f})" for f in factors)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            if binomial:
                model = smf.gee(
                    f"accepted ~ {right}",
                    "participant",
                    data,
                    family=sm.families.Binomial(),
                    cov_struct=sm.cov_struct.Exchangeable(),
                )
                fitted = model.fit(cov_type="bias_reduced")
                result.variance["within_participant_correlation"] = float(
                    model.cov_struct.dep_params
                )
            else:
                model = smf.mixedlm(f"outcome_value ~ {right}", data, groups=data["participant"])
                fitted = _fit_mixed(model, caught)
                between, within = float(fitted.cov_re.iloc[0, 0]), float(fitted.scale)
                result.variance.update(
                    participant_intercept=between,
                    residual=within,
                    icc=between / (between + within) if between + within > 0 else math.nan,
                )
        params = np.asarray(fitted.params, dtype=float)
        names = list(fitted.model.exog_names)
        cov = np.asarray(fitted.cov_params(), dtype=float)[: len(names), : len(names)]
    except np.linalg.LinAlgError:
        result.error = (
            "the model could not be fitted: its factors are confounded in these data (for "
            "example every participant met the conditions in the same positions)"
        )
        return
    except (ValueError, ZeroDivisionError) as exc:
        result.error = f"the model could not be fitted: {exc}"
        return
    result.notes += _warning_notes(caught)
    result.coefficients = _coefficients(names, params[: len(names)], cov, binomial)
    result.tests = _term_tests(names, params[: len(names)], cov, factors)
    if not binomial:
        # Every fixed effect varies within participants: the "between-within" denominator
        # df (SAS's DDFM=BETWITHIN) is the within-participant residual df.
        within = result.n_observations - result.n_participants - (len(names) - 1)
        result.tests = [_with_f(t, within) for t in result.tests]
    if not all(math.isfinite(c.se) for c in result.coefficients):
        result.error = "the model did not give finite standard errors (separation or no data)"


def _fit_mixed(model: Any, caught: list[warnings.WarningMessage]) -> Any:
    """REML fit; when the gradient optimizers fail (typically with the participant
    variance at its boundary 0), Nelder-Mead from the same start, keeping the better."""
    fitted = model.fit(reml=True)
    if fitted.converged and not any("failed" in str(w.message) for w in caught):
        return fitted
    retry = model.fit(reml=True, method=["nm"], maxiter=20_000)
    if retry.converged and retry.llf >= fitted.llf:
        caught.clear()  # the first attempt's failures no longer describe the result
        return retry
    return fitted


def _warning_notes(caught: list[warnings.WarningMessage]) -> list[str]:
    seen: list[str] = []
    for warning in caught:
        text = f"statsmodels: {str(warning.message).strip()}"
        if text not in seen:
            seen.append(text)
    return seen


def _split(name: str) -> tuple[str, str]:
    """``C(condition)[T.copy]`` -> (condition, copy)."""
    if name == "Intercept":
        return "Intercept", ""
    factor = name[2 : name.index(")")]
    return factor, name[name.index("[T.") + 3 : -1]


def _coefficients(
    names: list[str], params: np.ndarray[Any, Any], cov: np.ndarray[Any, Any], binomial: bool
) -> list[Coefficient]:
    rows = []
    for index, name in enumerate(names):
        estimate, variance = float(params[index]), float(cov[index, index])
        se = math.sqrt(variance) if variance >= 0 else math.nan
        z = estimate / se if se > 0 else math.nan
        p = float(2 * norm.sf(abs(z))) if math.isfinite(z) else math.nan
        low, high = estimate - Z95 * se, estimate + Z95 * se
        term, level = _split(name)
        odds = (_exp(estimate), _exp(low), _exp(high)) if binomial and term != "Intercept" else None
        rows.append(
            Coefficient(term, level, estimate, se, z, p, low, high, *(odds or (None, None, None)))
        )
    return rows


def _exp(value: float) -> float:
    return math.exp(value) if value < 700 else math.inf


def _term_tests(
    names: list[str], params: np.ndarray[Any, Any], cov: np.ndarray[Any, Any], factors: list[str]
) -> list[TermTest]:
    """Joint Wald chi-squared test that all of a factor's coefficients are zero."""
    tests = []
    for factor in factors:
        index = [i for i, name in enumerate(names) if _split(name)[0] == factor]
        estimate = params[index]
        try:
            statistic = float(estimate @ np.linalg.solve(cov[np.ix_(index, index)], estimate))
        except np.linalg.LinAlgError:
            statistic = math.nan
        p = float(chi2_distribution.sf(statistic, len(index))) if math.isfinite(statistic) else 1
        tests.append(TermTest(factor, statistic, len(index), p))
    return tests


def _with_f(test: TermTest, df_denominator: int) -> TermTest:
    if df_denominator < 1 or not math.isfinite(test.chi2):
        return test
    f = test.chi2 / test.df
    p = float(f_distribution.sf(f, test.df, df_denominator))
    return TermTest(test.term, test.chi2, test.df, test.p, f, df_denominator, p)


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
        "reference level, averaged over participants."
        + why
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
