"""One rounding rule for every number the software shows: round the exact value, half away
from zero.

"Exact value": descriptives are computed in rational arithmetic from the data as written
(:func:`exact`), so a mean of 4.45 is 89/20 and shows as 4.5 in every table, never 4.4
because a binary float happened to fall just below 4.45. A standard deviation is the square
root of an exact variance, taken to 40 significant digits. Other statistics (chi-squared,
p-values, W) are rounded from the exact value of the double they are computed as.
"""

from __future__ import annotations

from decimal import ROUND_HALF_UP, Context, Decimal, localcontext
from fractions import Fraction

Number = float | int | Fraction | Decimal
RULE = (
    "rounded half away from zero from the exact value (means and medians in exact rational "
    "arithmetic from the values as exported, SDs to 40 significant digits)"
)
MAX_DENOMINATOR = 10_000
_SNAP_TOLERANCE = Fraction(1, 10**12)


def exact(value: float | int | str) -> Fraction:
    """The value as written, as a fraction. A double that is within 1e-12 (relative) of a
    fraction with denominator up to 10 000 is taken as that fraction: questionnaire scores
    are means of whole-number answers (53/12 is exported as 4.416666666666667)."""
    written = Fraction(value) if isinstance(value, str) else Fraction(repr(value))
    if written.denominator <= MAX_DENOMINATOR:
        return written
    candidate = written.limit_denominator(MAX_DENOMINATOR)
    if abs(candidate - written) <= _SNAP_TOLERANCE * max(Fraction(1), abs(written)):
        return candidate
    return written


def sqrt(value: Fraction) -> Decimal:
    """The square root of a non-negative fraction to 40 significant digits."""
    with localcontext(Context(prec=40)):
        return (Decimal(value.numerator) / Decimal(value.denominator)).sqrt()


def rounded(value: Number, digits: int) -> Decimal:
    """``value`` rounded to ``digits`` decimals, half away from zero, from its exact value."""
    if isinstance(value, Fraction):
        whole_digits = len(str(abs(value.numerator) // value.denominator))
        with localcontext(Context(prec=max(60, whole_digits + digits + 20))):
            decimal = Decimal(value.numerator) / Decimal(value.denominator)
    else:
        decimal = Decimal(value)  # a float's exact binary value
    # Enough digits for the integer part too: a finite double reaches 1.8e308 (a Wald
    # chi-squared from a near-singular fit), and quantize refuses to round to fewer digits
    # than the value has.
    precision = max(60, decimal.adjusted() + digits + 2)
    with localcontext(Context(prec=precision)):
        result = decimal.quantize(Decimal(1).scaleb(-digits), rounding=ROUND_HALF_UP)
    return abs(result) if result.is_zero() else result  # no "-0.0"


def fmt(value: Number | None, digits: int, missing: str = "undefined") -> str:
    """``value`` as text with ``digits`` decimals (see :func:`rounded`); ``missing`` for None."""
    if value is None:
        return missing
    return f"{rounded(value, digits):f}"


def fmt_p(value: float | None, missing: str = "undefined") -> str:
    """A p-value: 4 decimals, or ``< 0.0001``."""
    if value is None:
        return missing
    return "< 0.0001" if value < 0.0001 else fmt(value, 4)


def p_is(value: float | None, missing: str = "undefined") -> str:
    """A p-value after the letter p: ``= 0.0123``, ``< 0.0001`` (never ``= < 0.0001``)."""
    text = fmt_p(value, missing)
    return text if value is None or text.startswith("<") else f"= {text}"
