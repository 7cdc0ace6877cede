"""One rounding rule everywhere: the exact value, half away from zero."""

from __future__ import annotations

from decimal import Decimal
from fractions import Fraction

import pytest

from chameleons.experiment.stats import analyze, render_latex, render_text
from chameleons.experiment.stats.descriptive import describe
from chameleons.experiment.stats.rounding import exact, fmt, fmt_p, rounded


def test_half_away_from_zero_from_the_exact_value() -> None:
    assert fmt(Fraction(89, 20), 1) == "4.5"  # 4.45 exactly
    assert fmt(Fraction(-89, 20), 1) == "-4.5"
    assert fmt(Fraction(1, 20), 1) == "0.1"
    assert fmt(Fraction(-1, 100), 1) == "0.0"  # never "-0.0"
    assert fmt(0.125, 2) == "0.13"  # 0.125 is exact in binary
    # A double's exact value decides: the double nearest 2.675 is below it.
    assert fmt(2.675, 2) == "2.67"
    assert rounded(Decimal("2.5"), 0) == Decimal("3")
    assert fmt(None, 1) == "undefined"
    assert fmt(None, 1, "--") == "--"


def test_huge_finite_values_are_written_out_not_refused() -> None:
    # A near-singular model's Wald chi-squared can be 1e60 or more; it is a number to show,
    # and once made decimal.quantize raise InvalidOperation (a 500 on the analysis page).
    assert fmt(1e60, 2) == f"{int(1e60)}.00"  # the double's exact value, written out
    assert fmt(-1.7976931348623157e308, 1).startswith("-17976931348623157")
    assert fmt(Fraction(10**70, 3), 0) == str(10**70 // 3)


def test_exact_reads_the_value_as_written_and_recovers_item_means() -> None:
    assert exact(4.45) == Fraction(89, 20)
    assert exact(53 / 12) == Fraction(53, 12)  # exported as 4.416666666666667
    assert exact(3.14159) == Fraction(314159, 100000)  # not snapped to 355/113
    assert exact("4.45") == Fraction(89, 20)


def test_p_values() -> None:
    assert fmt_p(0.00004) == "< 0.0001"
    assert fmt_p(0.00915168885265007) == "0.0092"
    assert fmt_p(None) == "undefined"


def test_a_mean_of_4_45_is_4_5_in_every_rendering() -> None:
    """The double of the median and mean of 4.1 and 4.8 falls just below 4.45 (formatting
    it gave 4.4, while a typed 4.45 gave 4.5); the exact value is 4.45 and shows as 4.5 in
    every table."""
    values = [4.1, 4.8]
    assert (values[0] + values[1]) / 2 < 4.45  # the binary float is below 4.45...
    d = describe(values)
    assert d.exact_mean == d.exact_median == Fraction(89, 20)  # ...the exact value is 4.45
    assert d.cell() == "4.5, 4.5 ± 0.5"
    assert describe([4.45]).cell() == "4.5, 4.5 ± --"
    rows = [
        {"participant": str(p), "condition": c, "trust": v + (0.5 if c == "copy" else 0)}
        for p, v in enumerate(values)
        for c in ("natural", "copy", "still")
    ]
    analysis = analyze(rows, measures=["trust"])
    assert "4.5, 4.5 ± 0.5" in render_text(analysis)
    assert r"& 4.5 & $4.5\pm0.5$" in render_latex(analysis)


@pytest.mark.parametrize("values", [[1, 2], [4.25, 4.35], [2, 2, 3, 3], [7]])
def test_descriptives_are_exact(values: list[float]) -> None:
    d = describe(values)
    ordered = sorted(Fraction(str(v)) for v in values)
    n = len(values)
    mean = sum(ordered) / n
    assert d.exact_mean == mean
    assert d.exact_median == (ordered[(n - 1) // 2] + ordered[n // 2]) / 2
    if n > 1:
        variance = sum((v - mean) ** 2 for v in ordered) / (n - 1)
        assert d.sd == pytest.approx(float(variance) ** 0.5)
    else:
        assert d.sd is None
        assert d.exact_sd is None
