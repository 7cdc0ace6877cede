"""The paper's analysis from score rows (one per participant x condition).

For each measure: descriptives per condition, the Friedman test across conditions with a
Bonferroni correction over the measures (p x m, capped at 1), Kendall's W, the permutation
p-value (exact when feasible, as at the paper's 12 participants; else Monte Carlo), and
pairwise Wilcoxon signed-rank tests (Bonferroni over the pairs) only where the corrected
permutation p is below alpha. The asymptotic chi-squared p (R's ``friedman.test``) is
reported beside it. Rows are read and checked by
:mod:`.scores` (the view, exclusions, refusals). A participant without a value for every
condition of a measure is left out of that measure, with a note saying why; descriptives
are over the same complete cases as the test, so the table and the test describe the same
data.

One measure's test is :mod:`.measure_test`; the rows a view counts and the models fit,
:mod:`.view_rows`; here the whole analysis (tests, effect sizes, models, reliability).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

from chameleons.experiment.model import Questionnaire
from chameleons.experiment.stats.effect_sizes import BootstrapOptions, effect_sizes
from chameleons.experiment.stats.measure_test import (
    DEFAULT_PERMUTATIONS as DEFAULT_PERMUTATIONS,
)
from chameleons.experiment.stats.measure_test import MeasureAnalysis, analyze_measure
from chameleons.experiment.stats.measure_test import small_sample_notes as small_sample_notes
from chameleons.experiment.stats.measure_test import smallest_exact_p as smallest_exact_p
from chameleons.experiment.stats.models import ModelInputError, Models, fit_models
from chameleons.experiment.stats.numbers import finite
from chameleons.experiment.stats.reliability import Reliability
from chameleons.experiment.stats.scale_reliability import scale_reliability
from chameleons.experiment.stats.scores import (
    DEFAULT_VIEW,
    VIEW_TITLES,
    AnalysisError,
    LeftOut,
    Reader,
    Scale,
    View,
)
from chameleons.experiment.stats.suggestion_mix import SuggestionMix, suggestion_mix
from chameleons.experiment.stats.view_rows import (
    model_score_rows,
    model_suggestion_rows,
    view_conditions,
)
from chameleons.experiment.stats.wilcoxon import DEFAULT_RULE, WilcoxonRule

DEFAULT_MEASURES = ("accepted", "credibility", "likeability", "trust")
PAPER_CONDITION_ORDER = ("natural", "copy", "still")
PAPER_REFERENCE = "still"  # the models' default baseline: the robot without facial gestures
__all__ = [
    "DEFAULT_MEASURES",
    "PAPER_CONDITION_ORDER",
    "Analysis",
    "AnalysisError",
    "MeasureAnalysis",
    "Scale",
    "analyze",
    "order_conditions",
]


@dataclass(frozen=True)
class Analysis:
    conditions: list[str]
    measures: dict[str, MeasureAnalysis]
    alpha: float
    notes: list[str]
    view: View = DEFAULT_VIEW
    participants: list[str] = field(default_factory=list)  # in the view (before per-measure)
    left_out: list[LeftOut] = field(default_factory=list)  # whole participants, with why
    wilcoxon_rule: WilcoxonRule = DEFAULT_RULE
    models: Models | None = None
    # Cronbach's alpha per scored questionnaire, over the view's participants' answers.
    reliability: list[Reliability] = field(default_factory=list)
    # Optimal and random suggestions per condition (when the per-suggestion rows are given).
    suggestion_mix: SuggestionMix | None = None

    @property
    def view_title(self) -> str:
        return VIEW_TITLES[self.view]

    def summary(self) -> str:
        """How many participants the tests use and why others are not in them."""
        total = len(self.participants) + len(self.left_out)
        text = f"{total} participant{'s' if total != 1 else ''} in the data"
        if self.left_out:
            text += f"; {len(self.left_out)} left out of every test: " + "; ".join(
                f"{out.participant} ({out.reason})" for out in self.left_out
            )
        per_measure = [
            f"{m} n = {r.friedman.n}" + (f" (incomplete: {', '.join(r.excluded)})" if r.excluded
                                          else "")
            for m, r in self.measures.items()
        ]  # fmt: skip
        return f"{text}. Analysed {self.view_title}: {'; '.join(per_measure)}."

    def to_dict(self) -> dict[str, Any]:
        return {
            "view": self.view,
            "view_title": self.view_title,
            "conditions": self.conditions,
            "alpha": self.alpha,
            "participants": self.participants,
            "left_out": [asdict(out) for out in self.left_out],
            "summary": self.summary(),
            "wilcoxon_rule": self.wilcoxon_rule,
            "measures": {m: a.to_dict() for m, a in self.measures.items()},
            "notes": self.notes,
            "models": finite(self.models.to_dict()) if self.models else None,
            "reliability": [finite(r.to_dict()) for r in self.reliability],
            "suggestion_mix": finite(self.suggestion_mix.to_dict())
            if self.suggestion_mix
            else None,
        }


def analyze(
    rows: Iterable[Mapping[str, Any]],
    *,
    measures: Sequence[str] | None = None,
    condition_order: Sequence[str] | None = None,
    conditions: Sequence[str] | None = None,
    scales: Mapping[str, Scale] | None = None,
    view: View = DEFAULT_VIEW,
    alpha: float = 0.05,
    permutations: int | None = DEFAULT_PERMUTATIONS,
    seed: int = 0,
    wilcoxon_rule: WilcoxonRule = DEFAULT_RULE,
    row_name: str = "row",
    first_row: int = 1,
    bootstrap: BootstrapOptions | None = None,
    models: bool = False,
    suggestions: Iterable[Mapping[str, Any]] | None = None,
    reference: str | None = None,
    questionnaires: Sequence[Questionnaire] = (),
    answers: Iterable[Mapping[str, Any]] | None = None,
) -> Analysis:
    """Analyse score rows (keys ``participant``, ``condition`` and one per measure; optional
    ``planned_condition``, ``position``, ``deviation``, ``excluded``, ``exclusion_reason``,
    ``interaction_status``, as the export's scores table has them).

    ``conditions``: the study's condition ids (a row with another label is refused);
    ``condition_order``: the columns' order (default: the paper's, then the rest sorted);
    ``scales``: the values each measure can take (others are refused);
    ``view``: ``as_planned`` or ``as_run`` (see :mod:`.scores`); ``permutations``: the
    permutation p-value per measure is exact when feasible, otherwise Monte Carlo with that
    many resamples and ``seed`` (``None``: the default number); ``row_name``/``first_row``:
    how refusals number the rows (a CSV file's data start on line 2).

    ``bootstrap``: add effect sizes with bootstrap intervals per measure (over the
    participants of its Friedman test). ``models``: fit the regression models
    (:mod:`.models`) on the participants of the view, conditions as the view counts them:
    the score models from the rows (with their ``position``), the acceptance model from
    ``suggestions`` (per-suggestion rows), against ``reference`` (default: still, else the
    first condition). ``answers`` (the export's questionnaire rows) with the study's
    ``questionnaires``: Cronbach's alpha per scale over the view's participants.
    ``suggestions`` also give the suggestion mix per condition (:mod:`.suggestion_mix`)."""
    rows = list(rows)
    wanted = list(measures or DEFAULT_MEASURES)
    reader = Reader(wanted, conditions, scales or {}, view, row_name, first_row)
    table = reader.read(rows)
    found = table.conditions if conditions is None else table.conditions | set(conditions)
    ordered = order_conditions(found, condition_order)
    chosen = [m for m in wanted if m in table.measures]
    if not chosen:
        raise AnalysisError(f"no measure columns found (expected some of {wanted})")
    results = {
        m: analyze_measure(m, table, ordered, len(chosen), alpha, permutations, seed,
                            wilcoxon_rule)
        for m in chosen
    }  # fmt: skip
    if bootstrap is not None:
        results = {m: _with_effect_sizes(r, ordered, bootstrap) for m, r in results.items()}
    fitted = None
    per_suggestion = (
        None if suggestions is None else model_suggestion_rows(suggestions, table, view)
    )
    if models:
        baseline = reference or (PAPER_REFERENCE if PAPER_REFERENCE in ordered else None)
        try:
            fitted = fit_models(
                model_score_rows(rows, table, view, chosen),
                per_suggestion,
                measures=chosen,
                conditions=ordered,
                reference=baseline,
            )
        except ModelInputError as exc:
            raise AnalysisError(str(exc)) from exc
    rule = "R < 4.6" if wilcoxon_rule == "R<4.6" else "R >= 4.6"
    notes = [
        *table.notes,
        f"Bonferroni: Friedman p x {len(chosen)} measures (capped at 1); post-hoc Wilcoxon "
        f"signed-rank p x {math.comb(len(ordered), 2)} pairs, only where the corrected "
        f"permutation p (exact where feasible) < {alpha}. The asymptotic chi-squared p (R's "
        "friedman.test) is shown beside it; with few participants it is rough.",
        f"Wilcoxon signed-rank tests as R's wilcox.test(paired = TRUE) ({rule}): zero "
        "differences dropped; exact p below 50 pairs without zeros"
        + (" or ties" if wilcoxon_rule == "R<4.6" else " (conditional on ties)")
        + ", otherwise the normal approximation with continuity correction. V is R's "
        "statistic (rank sum of the positive differences first - second), W the smaller "
        "rank sum.",
    ]
    return Analysis(
        ordered,
        results,
        alpha,
        notes,
        view,
        table.participants,
        table.left_out,
        wilcoxon_rule,
        fitted,
        []
        if answers is None
        else scale_reliability(
            questionnaires,
            answers,
            table.participants,
            conditions=view_conditions(rows, view),
            condition_order=ordered,
            seed=seed,
        ),
        None if per_suggestion is None else suggestion_mix(per_suggestion, ordered, seed),
    )


def _with_effect_sizes(
    result: MeasureAnalysis, conditions: list[str], options: BootstrapOptions
) -> MeasureAnalysis:
    """The measure's effect sizes over the participants its Friedman test used."""
    blocks = list(result.values.values())
    effects = effect_sizes(blocks, conditions, options, key=result.measure)
    return replace(result, effect_sizes=effects)


def order_conditions(found: Iterable[str], preferred: Sequence[str] | None = None) -> list[str]:
    """``preferred`` order (default: the paper's natural, copy, still), others sorted after."""
    found = set(found)
    first = [c for c in (preferred or PAPER_CONDITION_ORDER) if c in found]
    return first + sorted(found - set(first))
