"""The post-hoc Wilcoxon signed-rank test against R's rules (``wilcox.test(paired = TRUE)``),
computed by the independent reference in :mod:`tests.experiment.r_wilcox`.

The battery: seeded random cases with n from 2 to 60 pairs, of the kinds the study produces
(accepted-suggestion counts 0..3: many ties and zeros; questionnaire means k/12 on 1..7;
continuous values without ties; with injected zeros; tied without zeros), under both R
rules (R < 4.6 and R >= 4.6)."""

from __future__ import annotations

import random

import pytest
from scipy import stats

from chameleons.experiment.stats import wilcoxon_pair
from chameleons.experiment.stats.wilcoxon import (
    EXACT,
    EXACT_CONDITIONAL,
    NORMAL,
    WILCOXON_RULES,
    signed_rank_test,
)
from tests.experiment.r_wilcox import r_wilcox_paired

KINDS = ("counts", "likert", "continuous", "zeros", "tied")


def case(kind: str, n: int, rng: random.Random) -> tuple[list[float], list[float]]:
    if kind == "counts":
        return [rng.randint(0, 3) for _ in range(n)], [rng.randint(0, 3) for _ in range(n)]
    if kind == "likert":
        return (
            [rng.randint(12, 84) / 12 for _ in range(n)],
            [rng.randint(12, 84) / 12 for _ in range(n)],
        )
    x = [rng.gauss(0, 1) for _ in range(n)]
    y = [rng.gauss(0.3, 1) for _ in range(n)]
    if kind == "zeros":
        for i in rng.sample(range(n), max(1, n // 5)):
            y[i] = x[i]
    if kind == "tied":  # equal magnitudes, no zeros
        for i in rng.sample(range(n), max(2, n // 3)):
            y[i] = x[i] + rng.choice((-1.0, 1.0))
    return x, y


BATTERY = [(kind, n, seed) for kind in KINDS for n in range(2, 61, 3) for seed in range(2)]


@pytest.mark.parametrize("rule", WILCOXON_RULES)
@pytest.mark.parametrize(("kind", "n", "seed"), BATTERY)
def test_battery_matches_r_rules(rule: str, kind: str, n: int, seed: int) -> None:
    x, y = case(kind, n, random.Random(f"{kind}/{n}/{seed}"))
    v, p, how = r_wilcox_paired(x, y, rule)
    result = signed_rank_test(x, y, rule)  # type: ignore[arg-type]
    if p is None:
        assert result.p is None
        return
    assert result.v == v
    assert result.p == pytest.approx(p, rel=1e-9, abs=1e-14)
    assert (result.method == NORMAL) == (how == "normal")


def test_the_battery_covers_every_branch() -> None:
    methods = set()
    for rule in WILCOXON_RULES:
        for kind, n, seed in BATTERY:
            x, y = case(kind, n, random.Random(f"{kind}/{n}/{seed}"))
            methods.add((rule, signed_rank_test(x, y, rule).method))
    assert {("R<4.6", EXACT), ("R<4.6", NORMAL), ("R>=4.6", EXACT)} <= methods
    assert {("R>=4.6", EXACT_CONDITIONAL), ("R>=4.6", NORMAL)} <= methods


def test_zeros_without_ties_use_the_normal_approximation() -> None:
    """The issue's example: 9 positive, distinct differences and 3 zeros. R drops the zeros
    and, because there were zeros, uses the normal approximation: p = 0.0092 (the exact
    test on the 9 would give 2/512 = 0.0039)."""
    x, y = [*range(1, 10), 0, 0, 0], [0] * 12
    result = signed_rank_test(x, y)
    assert result.method == NORMAL
    assert (result.v, result.n, result.zeros) == (45.0, 9, 3)
    assert round(result.p or 0, 4) == 0.0092
    assert signed_rank_test(list(range(1, 10)), [0] * 9).p == pytest.approx(2 / 512)


def test_hollander_wolfe_example_of_the_r_documentation() -> None:
    """?wilcox.test: Hamilton depression scale, 9 patients (Hollander & Wolfe 1973, 29f)."""
    x = [1.83, 0.50, 1.62, 2.48, 1.68, 1.88, 1.55, 3.06, 1.30]
    y = [0.878, 0.647, 0.598, 2.05, 1.06, 1.29, 1.06, 3.14, 1.29]
    result = signed_rank_test(x, y)
    assert result.v == 40
    assert result.method == EXACT
    assert result.p == pytest.approx(2 * 10 / 512)  # R: one-sided "greater" p = 0.01953


def test_ties_are_exact_doubles_as_in_r() -> None:
    """?wilcox.test: (4:2)/10 vs (3:1)/10 has no ties in double arithmetic (exact test),
    4:2 vs 3:1 has (normal approximation under R < 4.6)."""
    assert signed_rank_test([0.4, 0.3, 0.2], [0.3, 0.2, 0.1]).method == EXACT
    tied = signed_rank_test([4, 3, 2], [3, 2, 1])
    assert tied.ties
    assert tied.method == NORMAL
    assert signed_rank_test([4, 3, 2], [3, 2, 1], "R>=4.6").method == EXACT_CONDITIONAL


def test_scipy_agrees_where_its_rules_are_rs() -> None:
    """SciPy's exact test (no ties or zeros) and its corrected normal approximation with
    Wilcoxon's zero handling are the same rules: a second, outside reference."""
    rng = random.Random(5)
    for n in (5, 12, 30, 55):
        x, y = case("continuous", n, rng)
        ours = signed_rank_test(x, y)
        method = "exact" if n < 50 else "approx"
        theirs = stats.wilcoxon(x, y, method=method, correction=n >= 50)
        assert ours.w == float(theirs.statistic)
        assert ours.p == pytest.approx(float(theirs.pvalue), rel=1e-9)
    x, y = case("zeros", 40, rng)
    theirs = stats.wilcoxon(x, y, zero_method="wilcox", method="approx", correction=True)
    assert signed_rank_test(x, y).p == pytest.approx(float(theirs.pvalue), rel=1e-9)


def test_pair_reports_v_w_method_and_undefined() -> None:
    test = wilcoxon_pair("copy", "still", [3, 2, 2, 1, 3], [1, 2, 0, 0, 1], pairs=3)
    assert test.v == 10.0
    assert test.statistic == 0.0
    assert test.nonzero == 4
    assert "1 zero difference(s) dropped" in test.note
    assert test.method == NORMAL
    assert test.p_bonferroni == pytest.approx(min(1.0, 3 * (test.p or 0)))
    undefined = wilcoxon_pair("a", "b", [1, 2], [1, 2], pairs=3)
    assert undefined.p is None
    assert undefined.v is None
    assert "all differences are zero" in undefined.note
