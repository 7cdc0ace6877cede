"""``copy``: the participant's face exactly ``delay`` seconds ago (default 4.000 s).

The output at local time ``t`` is the participant's face interpolated linearly between the
two captured frames around ``t - delay`` (capture clock mapped to the local clock, see
:class:`~chameleons.worker.behaviours.history.ClockMapper`). Until ``delay`` has elapsed
since the first frame it holds the neutral face. The frames live in the context's bounded
history, so switching to ``copy`` mid-stream starts copying at once.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from chameleons.worker.behaviours.base import (
    HEAD_SLICE,
    Behaviour,
    BehaviourContext,
    BehaviourError,
    number_param,
    reject_unknown,
)
from chameleons.worker.behaviours.params import Param
from chameleons.worker.behaviours.registry import register_behaviour
from chameleons.worker.frames import F32Array

DEFAULT_DELAY = 4.0
# The worker keeps 12 s of participant history by default; a copy needs half a second of
# slack to interpolate around ``t - delay``.
MAX_DELAY = 11.5


@register_behaviour("copy")
class CopyBehaviour(Behaviour):
    parameters = {
        "delay": Param(
            "number", DEFAULT_DELAY, "Seconds between the participant's movement and the "
            "robot's copy of it (Bailenson & Yee 2005: 4 s).", minimum=0.0, maximum=MAX_DELAY,
        ),
    }  # fmt: skip

    def __init__(self, context: BehaviourContext, delay: float = DEFAULT_DELAY) -> None:
        super().__init__(context)
        if not math.isfinite(delay) or delay < 0:
            raise BehaviourError(f"delay must be a non-negative number, got {delay}")
        self.delay = delay

    @classmethod
    def from_params(cls, context: BehaviourContext, params: Mapping[str, Any]) -> Behaviour:
        reject_unknown(params, {"delay"})
        return cls(
            context,
            number_param(
                params, "delay", DEFAULT_DELAY, low=0.0, high=context.history_seconds - 0.5
            ),
        )

    def sample(self, t: float, out: F32Array) -> float:
        context = self.context
        used = context.history.sample(t - self.delay, out)
        if math.isnan(used):
            out[:] = context.neutral
        elif context.recentre_head:
            context.head_neutral.relative(out[HEAD_SLICE])
        return used

    @property
    def lag(self) -> float:
        return self.delay

    def describe(self) -> dict[str, Any]:
        return {"delay": self.delay}
