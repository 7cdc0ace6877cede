"""Power and sample-size planning by simulating the planned study.

For each planned number of participants N (multiples of the planner's balance period),
the design is the counterbalancing plan itself: each participant's condition order (so
the interaction positions) and item sets come from ``design.plan``. Under assumed
effects, data sets are simulated and analysed as the study will be:

- **accepted suggestions**: each participant has their own tendency (a normal random
  intercept on the logit scale, SD ``acceptance_sd``); a suggestion in condition c is
  accepted with probability ``logistic(logit(p_c) + u)``, independently, for the study's
  suggestions per interaction. ``p_c`` is thus the probability of a typical participant
  (u = 0). Analysed by the Friedman test on the per-interaction counts and by the
  acceptance model (GEE, :mod:`.models`: condition + position + item set);
- **a questionnaire score**: ``mean_c + b + e`` with a participant effect
  ``b ~ N(0, sd_between)`` and noise ``e ~ N(0, sd_within)``, clipped to the scale.
  Analysed by the Friedman test and by the score model (linear mixed model, condition +
  position, random intercept; its Wald test is computed in closed form for these complete
  balanced data sets, see :func:`balanced_lmm_wald`, and checked against statsmodels).

A test "rejects" when its p-value is below ``alpha / tests`` (the analysis's Bonferroni
over the measures). Power is the share of rejecting data sets, with its Monte Carlo
standard error ``sqrt(p (1 - p) / R)``; the N needed is the smallest planned N whose power
reaches the target. Nothing else differs between conditions in the simulation (no
position, item-set or suggestion-kind effects), so the models' other terms are nuisance.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2 as chi2_distribution
from scipy.stats import f as f_distribution

from chameleons.experiment.blocks import balance_period
from chameleons.experiment.design import plan
from chameleons.experiment.model import Study
from chameleons.experiment.stats.effect_sizes import kendall_w_batch
from chameleons.experiment.stats.numbers import finite

Array = NDArray[np.float64]
Progress = Callable[[int, int], None]
TESTS = ("accepted_friedman", "accepted_model", "score_friedman", "score_model")
TEST_LABELS = {
    "accepted_friedman": "accepted suggestions: Friedman test",
    "accepted_model": "accepted suggestions: acceptance model (GEE)",
    "score_friedman": "questionnaire score: Friedman test",
    "score_model": "questionnaire score: linear mixed model",
}
BATCH = 500  # replicates simulated at once (memory stays small)


class PowerError(ValueError):
    """Assumptions or settings the simulation cannot use."""


@dataclass(frozen=True)
class Assumptions:
    acceptance: dict[str, float]  # per condition: P(accept) for a typical participant
    scores: dict[str, float]  # per condition: mean questionnaire score
    acceptance_sd: float = 1.0  # SD of participants' tendencies (logit scale)
    score_sd_between: float = 0.7
    score_sd_within: float = 0.7
    scale: tuple[float, float] = (1.0, 7.0)


@dataclass(frozen=True)
class Settings:
    sample_sizes: tuple[int, ...]
    replicates: int = 1000  # data sets per N for the Friedman tests and the score model
    model_replicates: int = 200  # data sets per N for the acceptance model (GEE fits)
    alpha: float = 0.05
    tests: int = 4  # Bonferroni divisor: the measures the analysis tests
    target: float = 0.8
    seed: int = 0


@dataclass(frozen=True)
class Design:
    """Per participant (rows) and condition (columns): the interaction's position (1-based)
    and item set; ``suggestions`` per interaction."""

    conditions: tuple[str, ...]
    positions: NDArray[np.int64]
    item_sets: NDArray[np.str_]
    suggestions: int


@dataclass(frozen=True)
class Estimate:
    power: float
    se: float
    replicates: int
    failed: int = 0  # model fits that failed (counted as not rejecting)


@dataclass
class PowerResult:
    design: dict[str, Any]
    assumptions: Assumptions
    settings: Settings
    rows: list[dict[str, Any]] = field(default_factory=list)
    needed: dict[str, int | None] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe: an estimate without replicates has power and SE ``None``."""
        data: dict[str, Any] = finite(
            {
                "design": self.design,
                "assumptions": asdict(self.assumptions),
                "settings": asdict(self.settings),
                "tests": TEST_LABELS,
                "rows": self.rows,
                "needed": self.needed,
                "notes": self.notes,
            }
        )
        return data


def check(assumptions: Assumptions, settings: Settings, conditions: Sequence[str]) -> None:
    for name, values in (("acceptance", assumptions.acceptance), ("scores", assumptions.scores)):
        missing = [c for c in conditions if c not in values]
        if missing:
            raise PowerError(f"{name}: no value for condition(s) {', '.join(missing)}")
        unknown = [c for c in values if c not in conditions]
        if unknown:
            raise PowerError(f"{name}: unknown condition(s) {', '.join(unknown)}")
    if not all(0 < p < 1 for p in assumptions.acceptance.values()):
        raise PowerError("acceptance probabilities must be between 0 and 1 (exclusive)")
    low, high = assumptions.scale
    if not all(low <= m <= high for m in assumptions.scores.values()):
        raise PowerError(f"score means must lie on the scale {low:g}..{high:g}")
    if min(assumptions.acceptance_sd, assumptions.score_sd_between) < 0:
        raise PowerError("standard deviations cannot be negative")
    if assumptions.score_sd_within <= 0:
        raise PowerError("the within-participant SD must be positive")
    if not settings.sample_sizes or min(settings.sample_sizes) < 2:
        raise PowerError("sample sizes must be at least 2")
    if settings.replicates < 1 or settings.model_replicates < 0:
        raise PowerError("replicates must be positive")
    if not 0 < settings.alpha < 1 or settings.tests < 1 or not 0 < settings.target < 1:
        raise PowerError("alpha and the target power must be between 0 and 1; tests >= 1")


def simulate(
    designs: Mapping[int, Design],
    assumptions: Assumptions,
    settings: Settings,
    reference: str | None = None,
    progress: Progress | None = None,
) -> PowerResult:
    """Power of the four tests at each N of ``designs`` (N -> that N's design)."""
    first = next(iter(designs.values()))
    conditions = first.conditions
    check(assumptions, settings, conditions)
    baseline = reference if reference in conditions else conditions[0]
    result = PowerResult(
        design={
            "conditions": list(conditions),
            "suggestions_per_interaction": first.suggestions,
            "reference": baseline,
        },
        assumptions=assumptions,
        settings=settings,
    )
    level = settings.alpha / settings.tests
    total = len(designs) * (settings.replicates + settings.model_replicates)
    done = 0
    for n, design in sorted(designs.items()):
        rng = np.random.default_rng([settings.seed, n])
        counts, decisions = simulate_acceptance(design, assumptions, settings.replicates, rng)
        scores = simulate_scores(design, assumptions, settings.replicates, rng)
        estimates = {
            "accepted_friedman": _rate(friedman_p(counts) < level),
            "score_friedman": _rate(friedman_p(scores) < level),
            "score_model": _rate(balanced_lmm_p(scores, design, baseline) < level),
        }
        done += settings.replicates
        if progress:
            progress(done, total)
        model_p, failed = gee_p_values(
            decisions[: settings.model_replicates], design, baseline, _step(progress, done, total)
        )
        done += settings.model_replicates
        estimates["accepted_model"] = _rate(model_p < level, failed)
        result.rows.append({"n": n, **{t: asdict(estimates[t]) for t in TESTS}})
    for test in TESTS:
        reached = [row["n"] for row in result.rows if row[test]["power"] >= settings.target]
        result.needed[test] = min(reached) if reached else None
    result.notes = _notes(result, settings)
    return result


def _step(progress: Progress | None, done: int, total: int) -> Progress | None:
    if progress is None:
        return None
    return lambda step, _of: progress(done + step, total)


def _rate(rejected: NDArray[np.bool_], failed: int = 0) -> Estimate:
    replicates = len(rejected)
    if replicates == 0:
        return Estimate(math.nan, math.nan, 0, failed)
    power = float(rejected.mean())
    return Estimate(power, math.sqrt(power * (1 - power) / replicates), replicates, failed)


def _notes(result: PowerResult, settings: Settings) -> list[str]:
    notes = [
        f"a test rejects when p < {settings.alpha:g} / {settings.tests} "
        f"(Bonferroni over {settings.tests} measures)",
        "power +- its Monte Carlo standard error; the N needed is the smallest planned N "
        f"whose estimated power reaches {settings.target:.0%}",
    ]
    failed = sum(row["accepted_model"]["failed"] for row in result.rows)
    if failed:
        notes.append(f"{failed} acceptance-model fit(s) failed and count as not rejecting")
    return notes


def simulate_acceptance(
    design: Design, assumptions: Assumptions, replicates: int, rng: np.random.Generator
) -> tuple[Array, Array]:
    """Accepted counts (R, N, k) and the decisions behind them (R, N, k, suggestions)."""
    n, k = design.positions.shape
    logits = np.array([_logit(assumptions.acceptance[c]) for c in design.conditions])
    tendency = rng.normal(0.0, assumptions.acceptance_sd, size=(replicates, n, 1))
    probability = 1 / (1 + np.exp(-(logits[None, None, :] + tendency)))
    uniform = rng.random((replicates, n, k, design.suggestions))
    decisions = (uniform < probability[..., None]).astype(np.float64)
    return decisions.sum(axis=-1), decisions


def simulate_scores(
    design: Design, assumptions: Assumptions, replicates: int, rng: np.random.Generator
) -> Array:
    n, k = design.positions.shape
    means = np.array([assumptions.scores[c] for c in design.conditions])
    between = rng.normal(0.0, assumptions.score_sd_between, size=(replicates, n, 1))
    within = rng.normal(0.0, assumptions.score_sd_within, size=(replicates, n, k))
    low, high = assumptions.scale
    return np.asarray(np.clip(means + between + within, low, high), dtype=np.float64)


def _logit(p: float) -> float:
    return math.log(p / (1 - p))


def friedman_p(blocks: Array) -> Array:
    """Asymptotic Friedman p-values of ``blocks`` (..., n, k), tie-corrected; 1 where the
    statistic is undefined (every block tied), as the analysis never rejects then."""
    n, k = blocks.shape[-2], blocks.shape[-1]
    chi2 = kendall_w_batch(blocks) * n * (k - 1)
    return np.asarray(chi2_distribution.sf(chi2, k - 1), dtype=np.float64)


def _within_design(design: Design, reference: str) -> tuple[Array, list[int]]:
    """Participant-centred dummy columns of condition then position (the score model's
    fixed effects without the intercept), for observations ordered (participant,
    condition); and the indices of the condition columns."""
    n, k = design.positions.shape
    others = [j for j, c in enumerate(design.conditions) if c != reference]
    condition = np.zeros((n, k, len(others)))
    for column, j in enumerate(others):
        condition[:, j, column] = 1.0
    levels = sorted(set(design.positions.ravel().tolist()))[1:]
    position = np.stack([(design.positions == level) for level in levels], axis=-1)
    columns = np.concatenate([condition, position.astype(np.float64)], axis=-1)
    centred = columns - columns.mean(axis=1, keepdims=True)
    return centred.reshape(n * k, -1), list(range(len(others)))


def balanced_lmm_wald(scores: Array, design: Design, reference: str) -> Array:
    """Wald chi2 of condition in the REML random-intercept model, for complete data where
    every participant has each condition and each position once.

    Then the fixed effects are estimated within participants (GLS = the within-participant
    least squares, whatever the variances), and REML gives the residual variance
    ``SSE_within / df_within`` -- or, when that exceeds the between-participant mean
    square (the participant variance estimate would be negative, so it is 0), the pooled
    ``(SSE_within + SS_between) / (df_within + df_between)``. The Wald statistic is then
    the extra sum of squares of condition divided by that variance."""
    replicates, n, k = scores.shape
    x, condition = _within_design(design, reference)
    centred = (scores - scores.mean(axis=-1, keepdims=True)).reshape(replicates, n * k)
    full = _residual_ss(centred, x)
    reduced = _residual_ss(centred, np.delete(x, condition, axis=1))
    df_within = n * (k - 1) - np.linalg.matrix_rank(x)
    participant_means = scores.mean(axis=-1)
    ss_between = k * ((participant_means - participant_means.mean(-1, keepdims=True)) ** 2).sum(-1)
    residual = full / df_within
    pooled = (full + ss_between) / (df_within + n - 1)
    variance = np.where(ss_between / (n - 1) >= residual, residual, pooled)
    return np.asarray((reduced - full) / variance, dtype=np.float64)


def balanced_lmm_p(scores: Array, design: Design, reference: str) -> Array:
    """The score model's F-test p-values (as :mod:`.models` reports them: Wald / df against
    F with the within-participant residual df)."""
    n, k = design.positions.shape
    df = k - 1
    x, _ = _within_design(design, reference)
    df_within = n * (k - 1) - int(np.linalg.matrix_rank(x))
    wald = balanced_lmm_wald(scores, design, reference)
    return np.asarray(f_distribution.sf(wald / df, df, df_within), dtype=np.float64)


def _residual_ss(y: Array, x: Array) -> Array:
    if x.shape[1] == 0:
        return np.asarray((y**2).sum(axis=-1), dtype=np.float64)
    coefficients, *_ = np.linalg.lstsq(x, y.T, rcond=None)
    residuals = y - (x @ coefficients).T
    return np.asarray((residuals**2).sum(axis=-1), dtype=np.float64)


def gee_p_values(
    decisions: Array, design: Design, reference: str, progress: Progress | None = None
) -> tuple[NDArray[np.float64], int]:
    """p-values of the acceptance model's joint condition test, one statsmodels GEE fit
    per simulated data set (the model the analysis fits); failed fits give p = 1."""
    import statsmodels.api as sm

    replicates = len(decisions)
    exog, condition, groups = _gee_design(design, reference)
    p_values, failed = np.ones(replicates), 0
    for r in range(replicates):
        endog = decisions[r].reshape(-1)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fitted = sm.GEE(endog, exog, groups=groups, family=sm.families.Binomial(),
                                cov_struct=sm.cov_struct.Exchangeable()).fit(
                    cov_type="bias_reduced")  # fmt: skip
                estimate = np.asarray(fitted.params)[condition]
                covariance = np.asarray(fitted.cov_params())[np.ix_(condition, condition)]
                wald = float(estimate @ np.linalg.solve(covariance, estimate))
            if not math.isfinite(wald):
                raise ValueError("not finite")
            p_values[r] = chi2_distribution.sf(wald, len(condition))
        except (np.linalg.LinAlgError, ValueError, ZeroDivisionError):
            failed += 1
        if progress and (r + 1) % 10 == 0:
            progress(r + 1, replicates)
    return p_values, failed


def _gee_design(design: Design, reference: str) -> tuple[Array, list[int], Array]:
    """Rows ordered (participant, condition, suggestion): intercept, condition, position
    and item-set dummies (an item set that never varies is left out, as in the model)."""
    n, k = design.positions.shape
    m = design.suggestions
    others = [j for j, c in enumerate(design.conditions) if c != reference]
    columns = [np.ones((n, k))]
    columns += [np.broadcast_to(np.arange(k) == j, (n, k)).astype(float) for j in others]
    for level in sorted(set(design.positions.ravel().tolist()))[1:]:
        columns.append((design.positions == level).astype(float))
    sets = sorted(set(design.item_sets.ravel().tolist()))
    columns += [(design.item_sets == level).astype(float) for level in sets[1:]]
    exog = np.repeat(np.stack(columns, axis=-1).reshape(n * k, -1), m, axis=0)
    groups = np.repeat(np.arange(n), k * m).astype(np.float64)
    return exog, list(range(1, 1 + len(others))), groups


def planned_design(study: Study, participants: int, plan_seed: int = 0) -> Design:
    """The design of the first ``participants`` rows of the study's counterbalancing plan."""
    rows = plan(study, participants, plan_seed).rows
    conditions = study.condition_ids
    positions = np.zeros((participants, len(conditions)), dtype=np.int64)
    item_sets = np.empty((participants, len(conditions)), dtype=object)
    for i, row in enumerate(rows):
        for interaction in row.interactions:
            j = conditions.index(interaction.condition)
            positions[i, j] = interaction.position
            item_sets[i, j] = interaction.item_set
    return Design(conditions, positions, item_sets.astype(str), study.suggestions_per_interaction)


def default_sample_sizes(study: Study, periods: int = 5) -> tuple[int, ...]:
    """N = one balance period, two, ... (12, 24, ... for the paper's study)."""
    period = balance_period(study)
    return tuple(period * m for m in range(1, periods + 1))
