"""Fitting one regression model with statsmodels (:mod:`.models`): GEE for acceptance, a
REML mixed model for scores (Nelder-Mead when the gradient optimizers fail), then the
coefficients with 95% Wald intervals (odds ratios for the binomial model) and each term's
joint Wald test, with an F version for the mixed models."""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.stats import chi2 as chi2_distribution
from scipy.stats import f as f_distribution
from scipy.stats import norm

from chameleons.experiment.stats.model_results import Coefficient, ModelResult, TermTest

if TYPE_CHECKING:  # pandas is imported where it is used: the CLI starts faster
    import pandas as pd

Z95 = float(norm.ppf(0.975))


def fit_model(
    result: ModelResult, data: pd.DataFrame, factors: list[str], *, binomial: bool
) -> None:
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
