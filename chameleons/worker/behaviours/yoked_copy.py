"""``yoked_copy``: the robot replays another participant's recorded face at the same delay,
shaped by the same parameters as ``copy`` (channels, gain, mirror, jitter, bouts, only).

The control keeps the statistics of copying (how much, how often, how late the robot moves
after *someone's* movement) but not the contingency on this participant. The recording is
the other participant's face stream of a ``copy`` interaction, replayed from its start: at
``delay`` seconds into this interaction the robot shows what that participant did at 0 s,
as the robot showed it to them. Its head is re-centred on the recording's own mean head
pose (the first ``HEAD_NEUTRAL_S`` seconds), not this participant's.

What a study sets is the ``copy`` parameters plus ``clip`` (the recording to replay until a
``copy`` recording of another participant exists: the first participants). The server
chooses the recording per interaction and sends the worker ``path`` (see
``chameleons.backend.booth.behaviour``); standalone, ``seed`` replays the face simulator.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from chameleons.locations import resolve_marked_path
from chameleons.worker.behaviours.base import (
    HEAD_SLICE,
    Behaviour,
    BehaviourContext,
    BehaviourError,
)
from chameleons.worker.behaviours.clips import MotionClip, load_clip
from chameleons.worker.behaviours.copy import (
    COPY_PARAMETERS,
    MIRROR_INDEX,
    MIRROR_SIGN,
    CopyBehaviour,
)
from chameleons.worker.behaviours.natural import DEFAULT_CLIP, synthetic_clip
from chameleons.worker.behaviours.params import Declared, Param
from chameleons.worker.behaviours.registry import register_behaviour
from chameleons.worker.frames import F32Array

HEAD_NEUTRAL_S = 20.0
YOKED_PARAMETERS = Declared({
    **COPY_PARAMETERS,
    "clip": Param("text", DEFAULT_CLIP, "What is replayed until another participant's copy "
                  "interaction has been recorded (the first participants): a clip in the prompts "
                  "folder's _natural/, as natural's clip.", optional=True),
}, COPY_PARAMETERS.together)  # fmt: skip
_SOURCE_KEYS = {"path", "clip"}


@register_behaviour("yoked_copy")
class YokedCopyBehaviour(CopyBehaviour):
    parameters = YOKED_PARAMETERS
    contingent = False

    def __init__(self, context: BehaviourContext, clip: MotionClip, source: str,
                 delay: Any = None, **params: Any) -> None:  # fmt: skip
        super().__init__(context, delay, **params)
        self.clip, self.source = clip, source
        head = clip.vectors[clip.times <= HEAD_NEUTRAL_S, HEAD_SLICE]
        self.head_neutral = head.mean(axis=0).astype(np.float32)

    @classmethod
    def from_params(cls, context: BehaviourContext, params: Mapping[str, Any]) -> Behaviour:
        rest = {k: v for k, v in params.items() if k not in _SOURCE_KEYS | {"delay"}}
        path = params.get("path")
        if path is None and "seed" in params:  # standalone: the face simulator stands in
            clip, source = synthetic_clip(int(params["seed"])), f"synthetic:{params['seed']}"
        elif isinstance(path, str) and path:
            clip = load_clip(resolve_marked_path(path, context.locations),
                             rotation_factor=context.rotation_factor)  # fmt: skip
            source = path
        else:
            raise BehaviourError("yoked_copy needs a 'path' to another participant's recording "
                                 "(or a 'seed' for a synthetic face)")  # fmt: skip
        return cls(context, clip, source, params.get("delay"), **rest)

    def _copied(self, t: float, out: F32Array) -> float:
        """The recording at ``t`` on its own clock (0 when this behaviour started)."""
        u = t - self._start
        if math.isnan(u) or u < 0:
            return math.nan
        self.clip.sample(u % self.clip.duration, out)
        out[HEAD_SLICE] -= self.head_neutral
        if self.flip:
            out[:] = out[MIRROR_INDEX] * MIRROR_SIGN
        return t

    def describe(self) -> dict[str, Any]:
        return {**self.settings, "source": self.source, "duration": self.clip.duration}
