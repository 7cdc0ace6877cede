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
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from itertools import combinations
from typing import Any

from chameleons.experiment.model import Questionnaire
from chameleons.experiment.stats.descriptive import (
    Descriptive,
    PairwiseTest,
    bonferroni,
    describe,
    wilcoxon_pair,
)
from chameleons.experiment.stats.effect_sizes import BootstrapOptions, EffectSizes, effect_sizes
from chameleons.experiment.stats.friedman_test import (
    FriedmanResult,
    PermutationResult,
    friedman,
    permutation_p,
)
from chameleons.experiment.stats.models import ModelInputError, Models, fit_models
from chameleons.experiment.stats.numbers import finite
from chameleons.experiment.stats.reliability import Reliability
from chameleons.experiment.stats.rounding import fmt_p
from chameleons.experiment.stats.scale_reliability import scale_reliability
from chameleons.experiment.stats.scores import (
    DEFAULT_VIEW,
    VIEW_TITLES,
    AnalysisError,
    LeftOut,
    Reader,
    Scale,
    ScoreTable,
    View,
    missing_reason,
    session_reason,
)
from chameleons.experiment.stats.suggestion_mix import SuggestionMix, suggestion_mix
from chameleons.experiment.stats.wilcoxon import DEFAULT_RULE, WilcoxonRule

DEFAULT_MEASURES = ("accepted", "credibility", "likeability", "trust")
DEFAULT_PERMUTATIONS = 10_000  # Monte Carlo resamples where the exact p is too costly
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
class MeasureAnalysis:
    measure: str
    conditions: dict[str, Descriptive]
    friedman: FriedmanResult
    p_bonferroni: float | None
    permutation: PermutationResult | None
    permutation_p_bonferroni: float | None
    posthoc: list[PairwiseTest]
    posthoc_note: str
    excluded: list[str]  # participants without a value in every condition of this measure
    notes: list[str]
    # The analysed values: participant -> one value per condition (the plots draw these).
    values: dict[str, list[float]] = field(default_factory=dict, compare=False, repr=False)
    effect_sizes: EffectSizes | None = None

    @property
    def primary_p(self) -> tuple[float | None, float | None, str]:
        """The Friedman p the report leads with and the post-hoc tests are gated on: the
        permutation p (exact or Monte Carlo) when computed, else the asymptotic one; with
        its Bonferroni correction and what it is."""
        perm = self.permutation
        if perm is not None and perm.p is not None:
            how = "exact permutation" if perm.method == "exact" else "Monte Carlo permutation"
            return perm.p, self.permutation_p_bonferroni, how
        return self.friedman.p, self.p_bonferroni, "asymptotic chi-squared"

    def to_dict(self) -> dict[str, Any]:
        test = self.friedman
        friedman_dict: dict[str, Any] = {
            "n": test.n,
            "k": test.k,
            "chi2": test.chi2,
            "df": test.df,
            "p": test.p,
            "p_bonferroni": self.p_bonferroni,
            "kendall_w": test.kendall_w,
            "defined": test.chi2 is not None,
            "permutation": None,
            "primary": dict(zip(("p", "p_bonferroni", "method"), self.primary_p, strict=True)),
        }
        if self.permutation is not None:
            friedman_dict["permutation"] = {
                **asdict(self.permutation),
                "p_bonferroni": self.permutation_p_bonferroni,
            }
        return {
            "conditions": {c: d.to_dict() for c, d in self.conditions.items()},
            "friedman": friedman_dict,
            "posthoc": [t.to_dict() for t in self.posthoc],
            "posthoc_note": self.posthoc_note,
            "excluded_participants": self.excluded,
            "notes": self.notes,
            "effect_sizes": finite(self.effect_sizes.to_dict()) if self.effect_sizes else None,
        }


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
        m: _analyze_measure(m, table, ordered, len(chosen), alpha, permutations, seed,
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


def _view_condition(row: Mapping[str, Any], view: View) -> str:
    planned = str(row.get("planned_condition") or "").strip()
    return planned if view == "as_planned" and planned else str(row.get("condition")).strip()


def view_conditions(rows: Iterable[Mapping[str, Any]], view: View) -> dict[tuple[str, str], str]:
    """(participant, position) -> the condition the view counts that interaction as."""
    return {
        (str(row.get("participant")).strip(), str(row.get("position")).strip()): (
            _view_condition(row, view)
        )
        for row in rows
    }


def model_score_rows(
    rows: list[Mapping[str, Any]], table: ScoreTable, view: View, measures: Sequence[str]
) -> list[dict[str, Any]]:
    """The score rows the models use: the view's participants and conditions, the values
    as the tests read them (checked and parsed), and each row's position."""
    kept = set(table.participants)
    result = []
    for row in rows:
        participant = str(row.get("participant")).strip()
        if participant not in kept:
            continue
        condition = _view_condition(row, view)
        values = table.values.get((participant, condition), {})
        result.append(
            {
                "participant": participant,
                "condition": condition,
                **({"position": row["position"]} if "position" in row else {}),
                **{m: values.get(m) for m in measures},
            }
        )
    return result


def model_suggestion_rows(
    rows: Iterable[Mapping[str, Any]], table: ScoreTable, view: View
) -> list[dict[str, Any]]:
    """Per-suggestion rows of the view's participants, conditions as the view counts them."""
    kept = set(table.participants)
    return [
        {**row, "condition": _view_condition(row, view)}
        for row in rows
        if str(row.get("participant")).strip() in kept
    ]


def order_conditions(found: Iterable[str], preferred: Sequence[str] | None = None) -> list[str]:
    """``preferred`` order (default: the paper's natural, copy, still), others sorted after."""
    found = set(found)
    first = [c for c in (preferred or PAPER_CONDITION_ORDER) if c in found]
    return first + sorted(found - set(first))


def _analyze_measure(
    measure: str,
    table: ScoreTable,
    conditions: list[str],
    tests: int,
    alpha: float,
    permutations: int | None,
    seed: int,
    rule: WilcoxonRule,
) -> MeasureAnalysis:
    blocks, excluded, notes = [], [], []
    included: dict[str, list[float]] = {}
    for participant in table.participants:
        keys = [(participant, c) for c in conditions]
        values = [table.values.get(key, {}).get(measure) for key in keys]
        if any(v is None for v in values):
            missing = [
                c + (f" ({why})" if (why := missing_reason(table.status.get(key, ""))) else "")
                for c, key, v in zip(conditions, keys, values, strict=True)
                if v is None
            ]
            excluded.append(participant)
            session = session_reason(table.sessions.get(participant, ""))
            notes.append(
                f"{participant} left out of {measure}: no value for {', '.join(missing)}"
                + (f"; {session}" if session else "")
            )
        else:
            blocks.append([float(v) for v in values if v is not None])
            included[participant] = blocks[-1]
    test = friedman(blocks)
    if test.chi2 is None:
        notes.append(
            f"{measure}: Friedman statistic undefined: every participant's values are tied "
            "(or no complete participant)"
        )
    resamples = DEFAULT_PERMUTATIONS if permutations is None else permutations
    permutation = permutation_p(blocks, resamples=resamples, seed=seed) if blocks else None
    notes += small_sample_notes(measure, len(blocks), len(conditions), tests, alpha)
    descriptives = {c: describe([b[j] for b in blocks]) for j, c in enumerate(conditions)}
    result = MeasureAnalysis(
        measure=measure,
        conditions=descriptives,
        friedman=test,
        p_bonferroni=bonferroni(test.p, tests),
        permutation=permutation,
        permutation_p_bonferroni=None if permutation is None else bonferroni(permutation.p, tests),
        posthoc=[],
        posthoc_note="",
        excluded=excluded,
        notes=notes,
        values=included,
    )
    _, gate, how = result.primary_p
    posthoc, posthoc_note = _posthoc(blocks, conditions, gate, how, alpha, rule)
    return replace(result, posthoc=posthoc, posthoc_note=posthoc_note)


def smallest_exact_p(n: int, k: int) -> float:
    """The smallest permutation p any data of ``n`` participants and ``k`` conditions can
    give: every participant ordering the conditions the same way, without ties, has
    probability ``k! / (k!)^n`` under the null."""
    return float(math.factorial(k)) ** (1 - n) if n >= 1 and k >= 1 else 1.0


def small_sample_notes(measure: str, n: int, k: int, tests: int, alpha: float) -> list[str]:
    """Warnings for samples too small to test anything: one participant (Kendall's W is 1
    or undefined whatever they answered), or so few that no data could reach significance
    after the Bonferroni correction."""
    if n == 0 or k < 2:
        return []
    smallest = smallest_exact_p(n, k)
    notes = []
    if n == 1:
        notes.append(
            f"{measure}: only 1 participant: Kendall's W is 1 (or undefined) whatever the "
            "answers, and no test can say anything; do not report these numbers"
        )
    if smallest * tests >= alpha:
        notes.append(
            f"{measure}: n = {n} is too few: with {k} conditions the smallest possible exact "
            f"p is {fmt_p(smallest)}, so after Bonferroni over {tests} measure(s) no data "
            f"could reach p < {alpha:g}"
        )
    return notes


def _posthoc(
    blocks: list[list[float]],
    conditions: list[str],
    p_corrected: float | None,
    how: str,
    alpha: float,
    rule: WilcoxonRule,
) -> tuple[list[PairwiseTest], str]:
    if p_corrected is None:
        return [], "not done: the Friedman test is undefined"
    if p_corrected >= alpha:
        return [], f"not done: corrected Friedman p ({how}) >= {alpha}"
    pairs = list(combinations(range(len(conditions)), 2))
    tests = [
        wilcoxon_pair(
            conditions[i],
            conditions[j],
            [b[i] for b in blocks],
            [b[j] for b in blocks],
            len(pairs),
            rule,
        )
        for i, j in pairs
    ]
    return tests, f"Wilcoxon signed-rank, Bonferroni over {len(pairs)} pairs"
