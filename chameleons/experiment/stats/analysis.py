"""The paper's analysis from score rows (one per participant x condition).

For each measure: descriptives per condition, the Friedman test across conditions with a
Bonferroni correction over the measures (p x m, capped at 1), Kendall's W, optionally a
permutation p-value, and pairwise Wilcoxon signed-rank tests (Bonferroni over the pairs)
only where the corrected Friedman p is below alpha. A participant without a value for
every condition of a measure is left out of that measure, with a note; descriptives are
over the same complete cases as the test, so the table and the test describe the same data.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from itertools import combinations
from typing import Any

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

DEFAULT_MEASURES = ("accepted", "credibility", "likeability", "trust")
PAPER_CONDITION_ORDER = ("natural", "copy", "still")
PAPER_REFERENCE = "still"  # the models' default baseline: the robot without facial gestures
MISSING = {"", "na", "nan", "none", "null"}


class AnalysisError(ValueError):
    """The score rows cannot be analysed (e.g. a value is not a number)."""


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
    excluded: list[str]
    notes: list[str]
    blocks: list[list[float]] = field(default_factory=list, repr=False)
    effect_sizes: EffectSizes | None = None

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
        }
        if self.permutation is not None:
            friedman_dict["permutation"] = {
                **asdict(self.permutation),
                "p_bonferroni": self.permutation_p_bonferroni,
            }
        return {
            "conditions": {c: asdict(d) for c, d in self.conditions.items()},
            "friedman": friedman_dict,
            "posthoc": [asdict(t) for t in self.posthoc],
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
    models: Models | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "conditions": self.conditions,
            "alpha": self.alpha,
            "measures": {m: a.to_dict() for m, a in self.measures.items()},
            "notes": self.notes,
            "models": finite(self.models.to_dict()) if self.models else None,
        }


def analyze(
    rows: Iterable[Mapping[str, Any]],
    *,
    measures: Sequence[str] | None = None,
    condition_order: Sequence[str] | None = None,
    alpha: float = 0.05,
    permutations: int | None = None,
    seed: int = 0,
    bootstrap: BootstrapOptions | None = None,
    models: bool = False,
    suggestions: Iterable[Mapping[str, Any]] | None = None,
    reference: str | None = None,
) -> Analysis:
    """Analyse score rows (keys ``participant``, ``condition`` and one per measure).

    ``permutations``: when given, add a permutation p-value per measure (exact when
    feasible, otherwise Monte Carlo with that many resamples and ``seed``).
    ``bootstrap``: add effect sizes with bootstrap intervals per measure.
    ``models``: fit the regression models (:mod:`.models`): the score models from the
    rows (they need ``position``), the acceptance model from ``suggestions`` (per-suggestion
    rows), both against the ``reference`` condition (default: still, else the first)."""
    rows = list(rows)
    table, present = _read(rows, measures)
    conditions = order_conditions({c for _, c in _keys(table)}, condition_order)
    chosen = [m for m in (measures or DEFAULT_MEASURES) if m in present]
    if not chosen:
        raise AnalysisError(f"no measure columns found (expected some of {list(DEFAULT_MEASURES)})")
    results = {
        m: _analyze_measure(m, table, conditions, len(chosen), alpha, permutations, seed)
        for m in chosen
    }
    if bootstrap is not None:
        results = {m: _with_effect_sizes(r, conditions, bootstrap) for m, r in results.items()}
    fitted = None
    if models:
        baseline = reference or (PAPER_REFERENCE if PAPER_REFERENCE in conditions else None)
        try:
            fitted = fit_models(
                rows, suggestions, measures=chosen, conditions=conditions, reference=baseline
            )
        except ModelInputError as exc:
            raise AnalysisError(str(exc)) from exc
    notes = [
        f"Bonferroni: Friedman p x {len(chosen)} measures (capped at 1); post-hoc Wilcoxon "
        f"signed-rank p x {math.comb(len(conditions), 2)} pairs, only where corrected p < {alpha}."
    ]
    return Analysis(conditions, results, alpha, notes, fitted)


def _with_effect_sizes(
    result: MeasureAnalysis, conditions: list[str], options: BootstrapOptions
) -> MeasureAnalysis:
    """The measure's effect sizes over the participants its Friedman test used."""
    effects = effect_sizes(result.blocks, conditions, options, key=result.measure)
    return replace(result, effect_sizes=effects)


def order_conditions(found: Iterable[str], preferred: Sequence[str] | None = None) -> list[str]:
    """``preferred`` order (default: the paper's natural, copy, still), others sorted after."""
    found = set(found)
    first = [c for c in (preferred or PAPER_CONDITION_ORDER) if c in found]
    return first + sorted(found - set(first))


def _analyze_measure(
    measure: str,
    table: dict[tuple[str, str], dict[str, float | None]],
    conditions: list[str],
    tests: int,
    alpha: float,
    permutations: int | None,
    seed: int,
) -> MeasureAnalysis:
    participants = sorted({p for p, _ in _keys(table)}, key=_natural)
    blocks, included, excluded, notes = [], [], [], []
    for participant in participants:
        values = [table.get((participant, c), {}).get(measure) for c in conditions]
        if any(v is None for v in values):
            missing = [c for c, v in zip(conditions, values, strict=True) if v is None]
            excluded.append(participant)
            notes.append(
                f"participant {participant} excluded: no {measure} for {', '.join(missing)}"
            )
        else:
            blocks.append([float(v) for v in values if v is not None])
            included.append(participant)
    test = friedman(blocks)
    if test.chi2 is None:
        notes.append(
            "Friedman statistic undefined: every participant's values are tied (or no data)"
        )
    permutation = (
        None if permutations is None else permutation_p(blocks, resamples=permutations, seed=seed)
    )
    descriptives = {c: describe([b[j] for b in blocks]) for j, c in enumerate(conditions)}
    p_corrected = bonferroni(test.p, tests)
    posthoc, posthoc_note = _posthoc(blocks, conditions, p_corrected, alpha)
    return MeasureAnalysis(
        measure=measure,
        conditions=descriptives,
        friedman=test,
        p_bonferroni=p_corrected,
        permutation=permutation,
        permutation_p_bonferroni=None if permutation is None else bonferroni(permutation.p, tests),
        posthoc=posthoc,
        posthoc_note=posthoc_note,
        excluded=excluded,
        notes=notes,
        blocks=blocks,
    )


def _posthoc(
    blocks: list[list[float]], conditions: list[str], p_corrected: float | None, alpha: float
) -> tuple[list[PairwiseTest], str]:
    if p_corrected is None:
        return [], "not done: the Friedman test is undefined"
    if p_corrected >= alpha:
        return [], f"not done: corrected Friedman p >= {alpha}"
    pairs = list(combinations(range(len(conditions)), 2))
    tests = [
        wilcoxon_pair(
            conditions[i], conditions[j], [b[i] for b in blocks], [b[j] for b in blocks], len(pairs)
        )
        for i, j in pairs
    ]
    return tests, f"Wilcoxon signed-rank, Bonferroni over {len(pairs)} pairs"


def _read(
    rows: Iterable[Mapping[str, Any]], measures: Sequence[str] | None
) -> tuple[dict[tuple[str, str], dict[str, float | None]], set[str]]:
    table: dict[tuple[str, str], dict[str, float | None]] = {}
    present: set[str] = set()
    wanted = measures or DEFAULT_MEASURES
    for number, row in enumerate(rows, start=1):
        participant, condition = _text(row, "participant", number), _text(row, "condition", number)
        if (participant, condition) in table:
            raise AnalysisError(f"row {number}: participant {participant} has {condition} twice")
        present.update(m for m in wanted if m in row)
        table[(participant, condition)] = {m: _number(row.get(m), number, m) for m in wanted}
    return table, present


def _keys(table: Mapping[tuple[str, str], object]) -> Iterable[tuple[str, str]]:
    return table.keys()


def _text(row: Mapping[str, Any], column: str, number: int) -> str:
    value = row.get(column)
    if value is None or str(value).strip() == "":
        raise AnalysisError(f"row {number}: no {column}")
    return str(value).strip()


def _number(value: object, number: int, column: str) -> float | None:
    if value is None or (isinstance(value, str) and value.strip().lower() in MISSING):
        return None
    try:
        result = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise AnalysisError(f"row {number}, {column}: {value!r} is not a number") from None
    return None if math.isnan(result) else result


def _natural(participant: str) -> tuple[int, int | str]:
    """Participants 2 before 10; codes that are not numbers after, alphabetically."""
    return (0, int(participant)) if participant.isdigit() else (1, participant)
