"""What parameters a behaviour takes, declared by the behaviour and checked without it.

A behaviour class lists its parameters in ``parameters`` (name -> :class:`Param`). The
study loader checks every condition's ``params`` against that declaration when the study
is loaded (so a typo or an impossible value is a located error in the study file, not a
failed command in the middle of a session) and fills in the defaults, so the stored study
snapshot says exactly what ran. This module is plain Python: the loader can use the
declarations without building a behaviour.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

ParamKind = Literal["number", "integer", "boolean", "text", "choice", "structured"]
# A structured parameter's own check: (the value as stored, None) or (None, the problem).
Checker = Callable[[object], tuple[Any, str | None]]


@dataclass(frozen=True)
class Param:
    """One declared parameter. ``number``/``integer`` honour ``minimum``/``maximum``;
    ``choice`` takes one of ``choices``; ``text`` any non-empty text; ``structured`` is
    checked by ``checker`` (a number or a mapping, say) and described by ``shape``.
    ``optional``: when the study leaves it out it is not filled in (absent means the
    default), so a study written before the parameter existed stores the same params."""

    kind: ParamKind
    default: Any
    description: str = ""
    minimum: float | None = None
    maximum: float | None = None
    choices: tuple[str, ...] = field(default_factory=tuple)
    checker: Checker | None = None
    shape: str = ""
    optional: bool = False

    def check(self, value: object) -> tuple[Any, str | None]:
        """(the value as stored, None) or (None, what is wrong with it)."""
        checker = _CHECKERS[self.kind]
        return checker(self, value)

    def describe(self) -> str:
        if self.kind in ("number", "integer"):
            low = "" if self.minimum is None else f"{self.minimum:g}"
            high = "" if self.maximum is None else f"{self.maximum:g}"
            return f"a {self.kind} in {low}..{high}"
        if self.kind == "choice":
            return "one of " + ", ".join(self.choices)
        if self.kind == "structured":
            return self.shape or "a structured value"
        return "true or false" if self.kind == "boolean" else "a text"


def _number(param: Param, value: object) -> tuple[Any, str | None]:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return None, f"must be {param.describe()}, got {value!r}"
    if param.kind == "integer" and not float(value).is_integer():
        return None, f"must be {param.describe()}, got {value!r}"
    if (param.minimum is not None and value < param.minimum) or (
        param.maximum is not None and value > param.maximum
    ):
        return None, f"must be {param.describe()}, got {value!r}"
    return (int(value) if param.kind == "integer" else float(value)), None


def _boolean(param: Param, value: object) -> tuple[Any, str | None]:
    if not isinstance(value, bool):
        return None, f"must be true or false, got {value!r}"
    return value, None


def _text(param: Param, value: object) -> tuple[Any, str | None]:
    if not isinstance(value, str) or not value.strip():
        return None, f"must be a non-empty text, got {value!r}"
    return value.strip(), None


def _choice(param: Param, value: object) -> tuple[Any, str | None]:
    if value not in param.choices:
        return None, f"must be {param.describe()}, got {value!r}"
    return value, None


def _structured(param: Param, value: object) -> tuple[Any, str | None]:
    if param.checker is None:
        return value, None
    return param.checker(value)


_CHECKERS = {
    "number": _number,
    "integer": _number,
    "boolean": _boolean,
    "text": _text,
    "choice": _choice,
    "structured": _structured,
}


class Declared(dict[str, Param]):
    """A behaviour's declared parameters with an optional check of their combination
    (``together(values, given)`` -> ``(name, problem)`` pairs), run once every parameter
    is valid on its own: ``coexpress`` with a ``delay``, say."""

    def __init__(
        self, params: Mapping[str, Param],
        together: Callable[[dict[str, Any], Mapping[str, Any]], list[tuple[str, str]]]
        | None = None,
    ) -> None:  # fmt: skip
        super().__init__(params)
        self.together = together


def check_params(
    declared: Mapping[str, Param], given: Mapping[str, Any]
) -> tuple[dict[str, Any], list[tuple[str, str]]]:
    """The parameters with defaults filled in, and ``(name, problem)`` for every unknown
    name or bad value (an empty list when all is well)."""
    problems: list[tuple[str, str]] = []
    for name in given:
        if name not in declared:
            known = ", ".join(sorted(declared)) or "none"
            problems.append((str(name), f"unknown parameter (this behaviour takes: {known})"))
    values: dict[str, Any] = {}
    for name, param in declared.items():
        if name not in given:
            if not param.optional:
                values[name] = param.default
            continue
        value, problem = param.check(given[name])
        if problem is None:
            values[name] = value
        else:
            problems.append((name, problem))
    together = getattr(declared, "together", None)
    if not problems and together is not None:
        problems.extend(together(values, given))
    return values, problems
