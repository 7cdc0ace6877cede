"""A questionnaire score on condition, position and a continuous covariate (the
interaction's mimicry), random intercept per participant, REML (statsmodels' MixedLM):
the score models of :mod:`..models` with one numeric term added."""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.stats import norm

from chameleons.experiment.stats.models import Coefficient, ModelResult

Z95 = float(norm.ppf(0.975))


def fit_with_covariate(
    rows: list[dict[str, Any]], measure: str, covariate: str, conditions: Sequence[str],
    reference: str,
) -> ModelResult:  # fmt: skip
    import pandas as pd
    import statsmodels.formula.api as smf

    result = ModelResult(
        name=f"{measure}_by_{covariate}", outcome=measure, family="gaussian",
        method="linear mixed model, random intercept per participant, REML",
        formula=f"{measure} ~ C(condition) + C(position) + {covariate} + (1 | participant)",
        description=(f"The {measure} score of each interaction on condition, position and the "
                     f"interaction's {covariate} (a numeric covariate), with a random intercept "
                     f"per participant. The {covariate} coefficient is the change in {measure} "
                     f"points per unit of {covariate}, conditions and positions held equal."),
        reference={"condition": reference, "position": "1"},
    )  # fmt: skip
    data = pd.DataFrame(rows, columns=["participant", "condition", "position", covariate, measure])
    data = data.dropna()
    result.n_observations, result.n_participants = len(data), int(data["participant"].nunique())
    if result.n_participants < 2 or len(data) < 6:
        result.error = "needs interactions with mimicry and a score from at least two participants"
        return result
    if float(data[covariate].std()) == 0.0:
        result.error = f"{covariate} does not vary"
        return result
    terms = []
    for factor in ("condition", "position"):
        levels = sorted({str(v) for v in data[factor]})
        if len(levels) < 2:
            result.notes.append(f"{factor} left out: only one level in the data")
            continue
        first = reference if factor == "condition" and reference in levels else levels[0]
        order = [first, *[v for v in levels if v != first]]
        data[factor] = pd.Categorical(data[factor].astype(str), categories=order)
        terms.append(f"C({factor})")
    right = " + ".join([*terms, covariate])
    result.formula = f"{measure} ~ {right} + (1 | participant)"
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            fitted = smf.mixedlm(f"{measure} ~ {right}", data, groups=data["participant"]).fit(
                reml=True
            )
    except (ValueError, np.linalg.LinAlgError) as exc:
        result.error = f"the model could not be fitted: {exc}"
        return result
    result.notes += sorted({f"statsmodels: {str(w.message).strip()}" for w in caught})
    names = list(fitted.model.exog_names)
    params = np.asarray(fitted.params, dtype=float)[: len(names)]
    cov = np.asarray(fitted.cov_params(), dtype=float)[: len(names), : len(names)]
    for index, name in enumerate(names):
        estimate, se = float(params[index]), math.sqrt(max(float(cov[index, index]), 0.0))
        z = estimate / se if se > 0 else math.nan
        p = float(2 * norm.sf(abs(z))) if math.isfinite(z) else math.nan
        term, level = _split(name)
        result.coefficients.append(
            Coefficient(term, level, estimate, se, z, p, estimate - Z95 * se, estimate + Z95 * se)
        )
    between, within = float(fitted.cov_re.iloc[0, 0]), float(fitted.scale)
    result.variance.update(participant_intercept=between, residual=within)
    return result


def _split(name: str) -> tuple[str, str]:
    """``C(condition)[T.copy]`` -> (condition, copy); a numeric term keeps its name."""
    if name.startswith("C(") and "[T." in name:
        return name[2 : name.index(")")], name[name.index("[T.") + 3 : -1]
    return name, ""
