"""What the robot did per condition, from the interactions' recorded ``behaviour_params`` and
``behaviour_words`` (issue 31): the analysis groups by condition name, and this says, per
condition, which parameter sets ran and in how many interactions, so a condition whose
parameters varied within the study (a study file edited between participants) is visible
beside the descriptives.

The per-interaction ``seed`` (and ``yoked_copy``'s replayed ``path``) differ by design and
are not a variation. For a delay distribution the summary gives the distribution's own mean
and SD (uniform ``[a, b]``: ``(a + b) / 2`` and ``(b - a) / sqrt(12)``; normal: its mean and
sd, before truncation to 0..11.5 s), and beside it what was *realised*: the delays the worker
drew and showed (its ``copy_draw`` events, summarised per interaction in the export's
``realised_delay_mean_s``, ``realised_delay_sd_s``, ``delay_draws``), pooled over the
variant's interactions, and for ``intermittent`` the realised share of time copying
(``copy_fraction``, mean over interactions) and bouts per interaction (``copy_bouts``).
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
    realised: Realised | None = None  # what the worker drew and showed, when reported

    def to_dict(self) -> dict[str, Any]:
        return {"words": self.words, "interactions": self.interactions,
                "delay_mean_s": self.delay_mean_s, "delay_sd_s": self.delay_sd_s,
                "realised": None if self.realised is None else self.realised.to_dict()}  # fmt: skip


@dataclass(frozen=True)
class Realised:
    """The draws of a variant's interactions: delays pooled over all draws; the bouts'
    share of time and count per interaction (means over the interactions that had bouts)."""

    draws: int
    delay_mean_s: float | None
    delay_sd_s: float | None
    copy_fraction: float | None = None
    bouts_per_interaction: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"draws": self.draws, "delay_mean_s": self.delay_mean_s,
                "delay_sd_s": self.delay_sd_s, "copy_fraction": self.copy_fraction,
                "bouts_per_interaction": self.bouts_per_interaction}  # fmt: skip

    def words(self) -> str:
        parts = []
        if self.delay_mean_s is not None:
            sd = "" if self.delay_sd_s is None else f", SD {self.delay_sd_s:.2f} s"
            parts.append(f"realised delay mean {self.delay_mean_s:.2f} s{sd} "
                         f"({self.draws} draw{'s' if self.draws != 1 else ''})")  # fmt: skip
        if self.copy_fraction is not None:
            parts.append(f"copying {100 * self.copy_fraction:.0f}% of the time, "
                         f"{self.bouts_per_interaction:.1f} bouts per interaction")  # fmt: skip
        return "; ".join(parts)


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
    drawn: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
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
        drawn.setdefault((str(condition), key), []).append(row)
    summary = []
    for condition in sorted(found):
        ran = [Variant(w, n, *_delay_spread(p), realised(drawn[(condition, key)]))
               for key, (w, p, n) in found[condition].items()]  # fmt: skip
        summary.append(ConditionBehaviour(condition, tuple(ran)))
    return summary


def realised(rows: Iterable[Mapping[str, Any]]) -> Realised | None:
    """The realised columns of some interactions pooled (None when none drew anything): the
    delays' mean and SD over all their draws, from each interaction's n, mean and SD."""
    parts: list[tuple[int, float, float]] = []
    fractions, bouts = [], []
    for row in rows:
        n, m = _number(row.get("delay_draws")), _number(row.get("realised_delay_mean_s"))
        if n and m is not None:
            parts.append((int(n), m, _number(row.get("realised_delay_sd_s")) or 0.0))
        fraction, count = _number(row.get("copy_fraction")), _number(row.get("copy_bouts"))
        if fraction is not None and count:
            fractions.append(fraction)
            bouts.append(count)
    if not parts and not fractions:
        return None
    n_total = sum(n for n, _, _ in parts)
    mean = sum(n * m for n, m, _ in parts) / n_total if n_total else None
    sd: float | None = None
    if mean is not None and n_total > 1:
        squares = sum((n - 1) * s**2 + n * (m - mean) ** 2 for n, m, s in parts)
        sd = math.sqrt(squares / (n_total - 1))
    return Realised(n_total, mean, sd,
                    sum(fractions) / len(fractions) if fractions else None,
                    sum(bouts) / len(bouts) if bouts else None)  # fmt: skip


def worth_reporting(summary: Iterable[ConditionBehaviour]) -> bool:
    """Whether any condition's parameters varied or drew at random (delays, bouts)."""
    return any(c.varied or c.jittered or any(v.realised for v in c.variants) for c in summary)


def render_text(summary: Iterable[ConditionBehaviour], labels: Mapping[str, str]) -> str:
    lines = ["Robot behaviour per condition (recorded per interaction):"]
    for c in summary:
        flag = " (parameters varied within the study)" if c.varied else ""
        lines.append(f"  {labels.get(c.condition, c.condition)}{flag}:")
        for v in c.variants:
            delay = ("" if v.delay_mean_s is None else f"; delay distribution mean "
                     f"{v.delay_mean_s:.2f} s, SD {v.delay_sd_s:.2f} s")  # fmt: skip
            if v.realised is not None:
                delay += f"; {v.realised.words()}"
            elif v.delay_mean_s is not None:
                delay += " (no realised delays reported)"
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


def _number(value: Any) -> float | None:
    """A number from a row (the database's, or interactions.csv's text; empty: None)."""
    if isinstance(value, bool) or value is None or value == "":
        return None
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


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
