"""One measure's test across the conditions: descriptives per condition, the Friedman test
(asymptotic and permutation p, with the Bonferroni correction over the measures), the notes
on participants left out and samples too small to test anything, and the pairwise Wilcoxon
tests where the corrected Friedman p is below alpha (:mod:`chameleons.experiment.stats.analysis`
runs it for every measure)."""

from __future__ import annotations

import math
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
from chameleons.experiment.stats.effect_sizes import EffectSizes
from chameleons.experiment.stats.friedman_test import (
    FriedmanResult,
    PermutationResult,
    friedman,
    permutation_p,
)
from chameleons.experiment.stats.numbers import finite
from chameleons.experiment.stats.rounding import fmt_p
from chameleons.experiment.stats.scores import ScoreTable, missing_reason, session_reason
from chameleons.experiment.stats.wilcoxon import WilcoxonRule

DEFAULT_PERMUTATIONS = 10_000  # Monte Carlo resamples where the exact p is too costly


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


def analyze_measure(
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
