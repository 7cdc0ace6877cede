"""When a ``copy`` copies: the seeded bout schedule (``intermittent``) and jittered delays.

Both are functions of the time since the behaviour started and the seed only (random
access, no state that depends on how often the stage samples), so a test or an analysis can
rebuild exactly what a participant saw from the recorded seed.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

RAMP = 0.1  # seconds a bout takes to fade in and out (inside the bout)
DELAY_CROSSFADE = 0.3  # seconds over which a newly drawn delay takes over
_BOUTS, _DELAYS = 1, 2  # streams of the seed


class BoutSchedule:
    """Bouts of ``bout_s`` seconds; the rest before each is exponential with mean
    ``1 / rate_per_s`` (a Poisson process of onsets while resting)."""

    def __init__(self, rate_per_s: float, bout_s: float, seed: int) -> None:
        self.rate, self.bout = rate_per_s, bout_s
        self._rng = np.random.default_rng([seed, _BOUTS])
        self._onsets: list[float] = []
        self._end = 0.0  # the end of the last bout generated

    def _extend(self, u: float) -> None:
        while self._end <= u + self.bout:
            onset = self._end + float(self._rng.exponential(1.0 / self.rate))
            self._onsets.append(onset)
            self._end = onset + self.bout

    def bout_at(self, u: float) -> int:
        """The index of the bout running ``u`` seconds after the start, or -1."""
        if u < 0:
            return -1
        self._extend(u)
        i = bisect.bisect_right(self._onsets, u) - 1
        return i if i >= 0 and u < self._onsets[i] + self.bout else -1

    def weight(self, u: float) -> float:
        """1 inside a bout (ramping over :data:`RAMP` at its edges), 0 at rest."""
        i = self.bout_at(u)
        if i < 0:
            return 0.0
        into = u - self._onsets[i]
        return max(0.0, min(1.0, into / RAMP, (self.bout - into) / RAMP))

    def rest_before(self, i: int) -> float:
        """The rest (seconds) before bout ``i`` (from the start, or the end of bout i - 1)."""
        self._extend(0.0)
        while len(self._onsets) <= i:
            self._extend(self._end)
        return self._onsets[i] - (self._onsets[i - 1] + self.bout if i > 0 else 0.0)

    def onset(self, i: int) -> float:
        self.rest_before(i)
        return self._onsets[i]

    def bouts(self, until: float) -> list[tuple[float, float]]:
        """(onset, end) of every bout that starts before ``until``."""
        self._extend(until)
        return [(o, o + self.bout) for o in self._onsets if o < until]


class DelaySchedule:
    """The copy's delay at each moment: fixed, or drawn from a distribution once per
    ``block`` (a bout index, or ``floor(u / resample_s)``)."""

    def __init__(self, delay: float | Mapping[str, Any], seed: int, resample_s: float,
                 maximum: float) -> None:  # fmt: skip
        self.fixed = float(delay) if not isinstance(delay, Mapping) else None
        self.distribution = delay if isinstance(delay, Mapping) else None
        self.seed, self.resample_s, self.maximum = seed, resample_s, maximum
        self._draws: dict[int, float] = {}

    def draw(self, block: int) -> float:
        if self.fixed is not None:
            return self.fixed
        if block not in self._draws:
            rng = np.random.default_rng([self.seed, _DELAYS, max(block, 0)])
            dist = self.distribution or {}
            if "uniform" in dist:
                low, high = dist["uniform"]
                value = float(rng.uniform(low, high))
            else:
                value = float(rng.normal(dist["normal"]["mean"], dist["normal"]["sd"]))
            self._draws[block] = min(self.maximum, max(0.0, value))
        return self._draws[block]

    def block_at(self, u: float) -> int:
        """The index of the draw in force ``u`` seconds after the start (no intermittent)."""
        return max(0, math.floor(u / self.resample_s))

    def at(self, u: float) -> tuple[float, float, float]:
        """(delay, previous delay, weight of the delay): a new draw fades in over
        :data:`DELAY_CROSSFADE` seconds (weight 1: no previous one to blend)."""
        if self.fixed is not None:
            return self.fixed, self.fixed, 1.0
        block = self.block_at(u)
        into = u - block * self.resample_s
        if block == 0 or into >= DELAY_CROSSFADE:
            return self.draw(block), self.draw(block), 1.0
        return self.draw(block), self.draw(block - 1), into / DELAY_CROSSFADE
