"""What the robot did per condition, from the interactions' recorded ``behaviour_params`` and
``behaviour_words`` (issue 31): the analysis groups by condition name, and this says, per
condition, which parameter sets ran and in how many interactions, so a condition whose
parameters varied within the study (a study file edited between participants) is visible
beside the descriptives.

The per-interaction ``seed`` (and ``yoked_copy``'s replayed ``path``) differ by design and
are not a variation. For a delay distribution the summary gives the distribution's own mean
and SD (uniform ``[a, b]``: ``(a + b) / 2`` and ``(b - a) / sqrt(12)``; normal: its mean and
sd, before truncation to 0..11.5 s): the delays the worker actually drew are not recorded,
so their mean and SD cannot be reported (docs/design-space.md).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

PER_INTERACTION = ("seed", "path")  # differ per interaction by design
_SEED_WORDS = re.compile(r", seed -?\d+$")


@dataclass(frozen=True)
class Variant:
    words: str  # behaviour_words without the per-interaction seed
    interactions: int
    delay_mean_s: float | None = None  # a delay distribution's mean and SD (not realised)
    delay_sd_s: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"words": self.words, "interactions": self.interactions,
                "delay_mean_s": self.delay_mean_s, "delay_sd_s": self.delay_sd_s}  # fmt: skip


@dataclass(frozen=True)
class ConditionBehaviour:
    condition: str
    variants: tuple[Variant, ...]

    @property
    def varied(self) -> bool:
        return len(self.variants) > 1

    @property
    def jittered(self) -> bool:
        return any(v.delay_sd_s is not None for v in self.variants)

    def to_dict(self) -> dict[str, Any]:
        return {"condition": self.condition, "varied": self.varied,
                "variants": [v.to_dict() for v in self.variants]}  # fmt: skip


def robot_behaviour(
    interactions: Iterable[Mapping[str, Any]], participants: Iterable[str] | None = None
) -> list[ConditionBehaviour]:
    """Per condition as run (``condition``), the parameter sets recorded and their counts,
    over the interactions of ``participants`` (all when None) that set the robot up."""
    kept = None if participants is None else {str(p) for p in participants}
    found: dict[str, dict[str, tuple[str, dict[str, Any], int]]] = {}
    for row in interactions:
        params = _params(row.get("behaviour_params"))
        condition = row.get("condition")
        if params is None or not condition:
            continue
        if kept is not None and str(row.get("participant")) not in kept:
            continue
        shared = {k: v for k, v in params.items() if k not in PER_INTERACTION}
        key = json.dumps(shared, sort_keys=True)
        words = _SEED_WORDS.sub("", str(row.get("behaviour_words") or ""))
        variants = found.setdefault(str(condition), {})
        first_words, first_params, n = variants.get(key, (words, shared, 0))
        variants[key] = (first_words, first_params, n + 1)
    summary = []
    for condition in sorted(found):
        ran = [Variant(w, n, *_delay_spread(p)) for w, p, n in found[condition].values()]
        summary.append(ConditionBehaviour(condition, tuple(ran)))
    return summary


def worth_reporting(summary: Iterable[ConditionBehaviour]) -> bool:
    """Whether any condition's parameters varied or drew its delay at random."""
    return any(c.varied or c.jittered for c in summary)


def render_text(summary: Iterable[ConditionBehaviour], labels: Mapping[str, str]) -> str:
    lines = ["Robot behaviour per condition (recorded per interaction):"]
    for c in summary:
        flag = " (parameters varied within the study)" if c.varied else ""
        lines.append(f"  {labels.get(c.condition, c.condition)}{flag}:")
        for v in c.variants:
            delay = ("" if v.delay_mean_s is None else f"; delay distribution mean "
                     f"{v.delay_mean_s:.2f} s, SD {v.delay_sd_s:.2f} s (realised delays not "
                     "recorded)")  # fmt: skip
            lines.append(f"    {v.interactions} interaction{'s' if v.interactions != 1 else ''}: "
                         f"{v.words or '(no words recorded)'}{delay}")  # fmt: skip
    return "\n".join(lines) + "\n"


def _params(value: Any) -> dict[str, Any] | None:
    if isinstance(value, Mapping):
        return dict(value)
    if isinstance(value, str) and value.strip():
        try:
            loaded = json.loads(value)
        except ValueError:
            return None
        return loaded if isinstance(loaded, dict) else None
    return None


def _delay_spread(params: Mapping[str, Any]) -> tuple[float | None, float | None]:
    delay = params.get("delay")
    if not isinstance(delay, Mapping):
        return None, None
    if "uniform" in delay:
        low, high = (float(x) for x in delay["uniform"])
        return (low + high) / 2, (high - low) / math.sqrt(12)
    normal = delay.get("normal")
    if isinstance(normal, Mapping):
        return float(normal["mean"]), float(normal["sd"])
    return None, None
