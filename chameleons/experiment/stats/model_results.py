"""What the regression models report (:mod:`.models`): a model's coefficients with their
Wald intervals, its joint term tests, the sample, the formula and the words, or the error
that stopped it; and the error for rows a model cannot use."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any


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
