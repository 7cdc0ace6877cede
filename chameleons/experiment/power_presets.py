"""Sample-size presets for the design-space templates (issue 31; docs/design-space.md,
"Power presets").

No effect size for these manipulations could be verified from the cited papers (their
abstracts give directions, not sizes; docs/design-space.md says which), so the presets are
*sensitivity* figures, computed with statsmodels' power classes under stated assumptions:

- each template has three conditions within participants, analysed (as the analysis does)
  by a Friedman test and pairwise Wilcoxon signed-rank tests, Bonferroni over the three
  pairs: a pairwise contrast is tested at ``alpha / 3``, two-sided;
- the contrast's effect is Cohen's d_z (the mean paired difference over the SD of the
  differences); the paired t-test's N for 80 % power (:class:`TTestPower`) is divided by
  the Wilcoxon test's worst-case asymptotic relative efficiency against it, 0.864 (Hodges
  & Lehmann 1956; 3/pi = 0.955 under normality), and rounded up to the template's balance
  period (12 participants: the Williams design is exactly balanced there);
- the Friedman gate, the Bonferroni over several measures and dropouts are not modelled
  (``chameleons power`` simulates the whole procedure under effects the lab supplies).

Beside them, the effect each cited study's *own* sample could detect (80 % power,
alpha 0.05, two-sided): a fact about its design, not an estimate of the effect.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations

from statsmodels.stats.power import TTestIndPower, TTestPower

ALPHA = 0.05
POWER = 0.8
WILCOXON_ARE = 0.864  # the signed-rank test's lowest ARE against the t-test (Hodges-Lehmann)
CONVENTIONS = (0.2, 0.5, 0.8)  # Cohen's small, medium, large (conventions, not findings)
SIZES = (12, 24, 36, 48)  # the balanced sample sizes whose detectable effect is listed


@dataclass(frozen=True)
class TemplatePower:
    template: str
    conditions: tuple[str, ...]
    primary: tuple[str, str]  # the contrast the template is built to test
    sources: tuple[str, ...]  # the references its rationale cites (docs/design-space.md)
    balance_period: int = 12

    @property
    def pairs(self) -> int:
        return len(list(combinations(self.conditions, 2)))

    @property
    def alpha(self) -> float:
        """The pairwise tests' level: Bonferroni over the pairs."""
        return ALPHA / self.pairs


TEMPLATES = (
    TemplatePower("delay_sweep", ("copy_fast", "copy_slow", "yoked"), ("copy_fast", "copy_slow"),
                  ("Bailenson & Yee (2005)", "Kroczek & Mühlberger (2023)",
                   "Hale & Hamilton (2016)")),
    TemplatePower("channels", ("head", "face", "both"), ("head", "face"),
                  ("Bailenson & Yee (2005)",)),
    TemplatePower("partial_full", ("full", "nods", "still"), ("full", "nods"),
                  ("Riek, Paul & Robinson (2010)",)),
    TemplatePower("embodiment", ("copy_2d", "copy_3d", "copy_furhat"),
                  ("copy_2d", "copy_furhat"), ()),
)  # fmt: skip


@dataclass(frozen=True)
class Reference:
    """A cited study's verified sample and the effect its design could detect."""

    source: str
    design: str
    n: int  # participants (within) or per group (between)
    within: bool

    def detectable(self) -> float:
        if self.within:
            return paired_effect(self.n, ALPHA)
        value = TTestIndPower().solve_power(nobs1=self.n, alpha=ALPHA, power=POWER, ratio=1.0)
        return float(value)


REFERENCES = (
    Reference("Bailenson & Yee (2005)", "between participants, copy (4 s) vs another "
              "participant's recorded movements; 69 participants (press report), about "
              "34 per group", 34, within=False),
    Reference("Hale & Hamilton (2016), Study 1", "within, 50 participants: avatars "
              "mimicking (1 or 3 s) vs not", 50, within=True),
    Reference("Hale & Hamilton (2016), Study 2", "within, 40 participants, preregistered: "
              "mimicking vs not (no effect found)", 40, within=True),
    Reference("Kroczek & Mühlberger (2023)", "within, 40 participants, delays of an agent's "
              "congruent expression (growth-curve model, not a pairwise contrast)", 40,
              within=True),
)  # fmt: skip


def paired_n(d_z: float, alpha: float) -> float:
    """Pairs for 80 % power of a two-sided paired t-test (statsmodels)."""
    value = TTestPower().solve_power(effect_size=d_z, alpha=alpha, power=POWER,
                                     alternative="two-sided")  # fmt: skip
    return float(value)


def paired_effect(n: float, alpha: float) -> float:
    """The d_z a two-sided paired t-test on ``n`` pairs detects with 80 % power."""
    value = TTestPower().solve_power(nobs=n, alpha=alpha, power=POWER, alternative="two-sided")
    return float(value)


def planned_n(d_z: float, template: TemplatePower) -> int:
    """Participants for a pairwise Wilcoxon contrast of size ``d_z`` at the template's
    pairwise alpha, rounded up to its balance period."""
    wilcoxon = math.ceil(paired_n(d_z, template.alpha) / WILCOXON_ARE)
    return math.ceil(wilcoxon / template.balance_period) * template.balance_period


def detectable(n: int, template: TemplatePower) -> float:
    """The d_z a pairwise Wilcoxon contrast detects with ``n`` participants (80 % power):
    the paired t's at the ``n * ARE`` pairs it is worth."""
    return paired_effect(n * WILCOXON_ARE, template.alpha)


def preset_rows(template: TemplatePower) -> dict[str, list[tuple[str, str]]]:
    """The preset as label -> value rows, in the order docs and the CLI show them."""
    needed = [(f"d_z = {d:g}", f"{planned_n(d, template)} participants") for d in CONVENTIONS]
    sensitivity = [(f"N = {n}", f"d_z >= {detectable(n, template):.2f}") for n in SIZES]
    return {"needed": needed, "detectable": sensitivity}


def render(template: TemplatePower) -> str:
    rows = preset_rows(template)
    a, b = template.primary
    lines = [
        f"{template.template}: {', '.join(template.conditions)} (within participants)",
        f"  primary contrast {a} vs {b}; each of the {template.pairs} pairwise Wilcoxon "
        f"tests at alpha {ALPHA:g} / {template.pairs} = {template.alpha:.4f}, two-sided, "
        f"80% power",
        "  participants needed (conventional effect sizes, not published ones):",
        *(f"    {label}: {value}" for label, value in rows["needed"]),
        "  smallest effect detected:",
        *(f"    {label}: {value}" for label, value in rows["detectable"]),
        "  sources of the rationale: " + ("; ".join(template.sources) or "none"),
    ]
    return "\n".join(lines) + "\n"


def render_references() -> str:
    lines = ["What the cited studies' own samples could detect (80% power, alpha 0.05):"]
    for ref in REFERENCES:
        kind = "d_z" if ref.within else "d"
        lines.append(f"  {ref.source}: {kind} >= {ref.detectable():.2f} ({ref.design})")
    return "\n".join(lines) + "\n"


def by_name(name: str) -> TemplatePower | None:
    return next((t for t in TEMPLATES if t.template == name), None)
