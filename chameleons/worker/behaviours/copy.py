"""``copy``: the participant's face ``delay`` seconds ago (default 4.000 s), shaped by the
design-space parameters of :mod:`~chameleons.worker.behaviours.copy_params` (which channels,
gain, mirror, jittered delay, co-expression, bouts, congruent-only expressions).

The output at local time ``t`` is the participant's face interpolated linearly between the
two captured frames around ``t - delay`` (capture clock mapped to the local clock, see
:class:`~chameleons.worker.behaviours.history.ClockMapper`). Until ``delay`` has elapsed
since the first frame it holds the neutral face. The frames live in the context's bounded
history, so switching to ``copy`` mid-stream starts copying at once. Every channel not
copied stays at the neutral face; a copied channel is ``neutral + gain * (copied -
neutral)`` (blendshapes kept within 0..1).

What it drew at random is *realised* when the output first reaches it: each bout
(``intermittent``, with the rest before it and its delay) and each jittered delay. Those
are kept as :meth:`realised` reports, which the behaviour stage publishes as ``copy_draw``
events (the server logs them per interaction, the export summarises them). A fixed delay
without bouts draws nothing and reports nothing.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from chameleons.worker.behaviours import copy_params as cp
from chameleons.worker.behaviours.base import (
    HEAD_SLICE,
    NO_INPUT,
    VECTOR_SIZE,
    Behaviour,
    BehaviourContext,
    BehaviourError,
)
from chameleons.worker.behaviours.copy_timing import BoutSchedule, DelaySchedule
from chameleons.worker.behaviours.params import Declared, Param, check_params
from chameleons.worker.behaviours.registry import register_behaviour
from chameleons.worker.frames import MIRROR_PERMUTATION, MOUTH_JAW_INDICES, N_BLENDSHAPES, F32Array

DEFAULT_DELAY = cp.DEFAULT_DELAY
MAX_DELAY = cp.MAX_DELAY
_H = N_BLENDSHAPES
# The mirror image of a face vector: out = vector[MIRROR_INDEX] * MIRROR_SIGN.
MIRROR_INDEX = np.concatenate([MIRROR_PERMUTATION, [_H, _H + 1, _H + 2],
                          _H + 3 + np.array([3, 4, 5, 0, 1, 2])])  # fmt: skip
MIRROR_SIGN = np.ones(VECTOR_SIZE, dtype=np.float32)
MIRROR_SIGN[[_H, _H + 2]] = -1
MIRROR_SIGN[_H + 3 :] = np.array([-1, 1, -1, -1, 1, -1], dtype=np.float32)
_MOUTH_JAW = np.array(MOUTH_JAW_INDICES)


def _mirror_param(value: object) -> tuple[Any, str | None]:
    if value is None or isinstance(value, bool):
        return value, None
    return None, (
        f"must be true (mirror image), false (same side) or null (the booth's), got {value!r}"
    )


COPY_PARAMETERS = Declared({
    "delay": Param("structured", DEFAULT_DELAY, "Seconds between the participant's movement and "
                   "the robot's copy of it (Bailenson & Yee 2005: 4 s), or a distribution.",
                   checker=cp.check_delay, shape=cp._DELAY_SHAPE),
    "channels": Param("structured", "all", "What is copied; the rest stays neutral.",
                      checker=cp.check_channels, shape=cp._CHANNELS_SHAPE, optional=True),
    "gain": Param("structured", 1.0, "How much: a number or channel: number.",
                  checker=cp.check_gain, shape="a number in 0..3 or a mapping channel: number",
                  optional=True),
    "mirror": Param("structured", None, "Mirror image (true) or same side (false); absent: "
                    "the booth's mirror setting.", checker=_mirror_param,
                    shape="true, false or null", optional=True),
    "coexpress": Param("boolean", False, "Zero lag (co-expression; no anticipation claimed).",
                       optional=True),
    "delay_resample_s": Param("number", 10.0, "A jittered delay is drawn anew this often "
                              "(per bout with intermittent).", minimum=0.5, maximum=600.0,
                              optional=True),
    "intermittent": Param("structured", None, "Copy in bouts: {rate_per_s, bout_s, rest}.",
                          checker=cp.check_intermittent,
                          shape="{rate_per_s, bout_s, rest: neutral|natural}", optional=True),
    "only": Param("structured", None, "Congruent-only: copy just these named expressions ("
                  + ", ".join(cp.EXPRESSIONS) + ").", checker=cp.check_only,
                  shape="a list of " + ", ".join(cp.EXPRESSIONS), optional=True),
    "seed": Param("integer", 0, "Seed of the random draws (absent: the interaction's id).",
                  minimum=0, maximum=2**31 - 1, optional=True),
}, cp.check_together)  # fmt: skip


def checked(params: Mapping[str, Any], history_seconds: float) -> dict[str, Any]:
    """The parameters as :data:`COPY_PARAMETERS` stores them, or a BehaviourError."""
    values, problems = check_params(COPY_PARAMETERS, params)
    delay = values.get("delay")
    if not problems and isinstance(delay, float) and delay > history_seconds - 0.5:
        problems.append(("delay", f"must be within 0..{history_seconds - 0.5:g} (the history)"))
    if problems:
        raise BehaviourError("; ".join(f"{name}: {problem}" for name, problem in problems))
    return values


@register_behaviour("copy")
class CopyBehaviour(Behaviour):
    parameters = COPY_PARAMETERS
    contingent = True  # copies this participant (yoked_copy: another one's recording)

    def __init__(self, context: BehaviourContext, delay: Any = None, **params: Any) -> None:
        """``delay`` and ``params`` as a study gives them (absent: the defaults)."""
        super().__init__(context)
        given = params if delay is None else {"delay": delay, **params}
        self.params = checked(given, context.history_seconds)
        s = cp.settings_of(self.params)
        self.settings = s
        seed = int(s["seed"] or 0)
        self.delays = DelaySchedule(s["delay"], seed, float(s["delay_resample_s"]),
                                    context.history_seconds - 0.5)  # fmt: skip
        self.delay = self.delays.draw(0)
        intermittent = s["intermittent"]
        self.bouts = (BoutSchedule(intermittent["rate_per_s"], intermittent["bout_s"], seed)
                      if intermittent else None)  # fmt: skip
        self.rest_natural = bool(intermittent) and intermittent["rest"] == "natural"
        self.flip = s["mirror"] is not None and s["mirror"] != context.input_mirrored
        self.scale = np.zeros(VECTOR_SIZE, dtype=np.float32)
        channels = s["channels"]
        names = cp.expand([channels] if isinstance(channels, str) else channels)
        gain = s["gain"]
        for name in names:
            self.scale[cp.CHANNEL_INDEX[name]] = 1.0
        self.gains = np.ones(VECTOR_SIZE, dtype=np.float32)
        if isinstance(gain, dict):
            for key, value in gain.items():
                for name in cp.expand([key]):
                    self.gains[cp.CHANNEL_INDEX[name]] = value
        else:
            self.gains[:] = gain
        self.scale *= self.gains
        self.expressions = [
            (np.array([cp.CHANNEL_INDEX[n] for n in e.trigger]),
             np.array([cp.CHANNEL_INDEX[n] for n in e.channels]), e.threshold)
            for e in (cp.EXPRESSIONS[name] for name in (s["only"] or []))
        ]  # fmt: skip
        self._start = math.nan
        self._lag = self.delay
        self._prev = np.zeros(VECTOR_SIZE, dtype=np.float32)
        self._rest = np.zeros(VECTOR_SIZE, dtype=np.float32)
        self._idle = np.zeros(VECTOR_SIZE, dtype=np.float32)
        self._clip: Any = None
        self._seed = seed
        self._reached = -1  # the last bout or delay block reported
        self._reports: list[dict[str, Any]] = []
        if self.rest_natural:
            from chameleons.worker.behaviours.natural import synthetic_clip

            self._clip = synthetic_clip(seed)

    @classmethod
    def from_params(cls, context: BehaviourContext, params: Mapping[str, Any]) -> Behaviour:
        rest = {k: v for k, v in params.items() if k != "delay"}
        return cls(context, params.get("delay"), **rest)

    def start(self, t: float) -> None:
        self._start = t

    def _copied(self, t: float, out: F32Array) -> float:
        """The participant's (processed) face at local time ``t``: re-centred, mirrored."""
        context = self.context
        used = context.history.sample(t, out)
        if math.isnan(used):
            return used
        if context.recentre_head:
            context.head_neutral.relative(out[HEAD_SLICE])
        if self.flip:
            out[:] = out[MIRROR_INDEX] * MIRROR_SIGN
        return used

    def sample(self, t: float, out: F32Array) -> float:
        if math.isnan(self._start):
            self._start = t
        u = t - self._start
        neutral = self.context.neutral
        w_bout = 1.0
        if self.bouts is not None:
            bout = self.bouts.bout_at(u)
            w_bout = self.bouts.weight(u)
            delay, previous, w_delay = self.delays.draw(max(bout, 0)), 0.0, 1.0
            if bout > self._reached:
                self._reach_bout(bout)
        else:
            delay, previous, w_delay = self.delays.at(u)
            if self.delays.fixed is None and self.delays.block_at(u) > self._reached:
                self._reach_block(self.delays.block_at(u))
        self._lag = delay
        if w_bout <= 0.0:
            self._rest_face(u, out)
            return NO_INPUT
        used = self._copied(t - delay, out)
        if math.isnan(used):
            out[:] = neutral
            return NO_INPUT
        if w_delay < 1.0 and not math.isnan(self._copied(t - previous, self._prev)):
            out -= self._prev
            out *= np.float32(w_delay)
            out += self._prev
        out -= neutral
        out *= self._scale_for(out)
        out += neutral
        np.clip(out[:N_BLENDSHAPES], 0.0, 1.0, out=out[:N_BLENDSHAPES])
        if w_bout < 1.0:
            self._rest_face(u, self._rest)
            out -= self._rest
            out *= np.float32(w_bout)
            out += self._rest
        return used if self.contingent else NO_INPUT

    def _scale_for(self, deviation: F32Array) -> F32Array:
        """Per channel: the gain where copied, 0 where not (``only``: its expressions'
        channels while their trigger is at or above the threshold)."""
        if not self.expressions:
            return self.scale
        scale = np.zeros(VECTOR_SIZE, dtype=np.float32)
        for trigger, channels, threshold in self.expressions:
            if float(np.max(np.abs(deviation[trigger]))) >= threshold:
                scale[channels] = self.gains[channels]
        return scale

    def _rest_face(self, u: float, out: F32Array) -> None:
        """Between bouts: neutral, or (``rest: natural``) the synthetic face's idle motion
        on the copied channels (its mouth and jaw held still)."""
        neutral = self.context.neutral
        out[:] = neutral
        if self._clip is None:
            return
        idle = self._idle
        self._clip.sample(u % self._clip.duration, idle)
        idle[_MOUTH_JAW] = neutral[_MOUTH_JAW]
        out += (self.scale != 0) * (idle - neutral)

    def _reach_bout(self, bout: int) -> None:
        assert self.bouts is not None
        self._reached = bout
        onset, rest = self.bouts.onset(bout), self.bouts.rest_before(bout)
        self._reports.append({"bout": bout, "at_s": onset, "t": self._start + onset,
                              "delay_s": self.delays.draw(bout), "bout_s": self.bouts.bout,
                              "rest_s": rest, "seed": self._seed})  # fmt: skip

    def _reach_block(self, block: int) -> None:
        self._reached = block
        at = block * self.delays.resample_s
        self._reports.append({"block": block, "at_s": at, "t": self._start + at,
                              "delay_s": self.delays.draw(block), "seed": self._seed})  # fmt: skip

    def realised(self) -> list[dict[str, Any]]:
        """The draws reached since the last call (``t``: the local time each took effect;
        ``at_s``: the same, since the behaviour started)."""
        reports, self._reports = self._reports, []
        return reports

    @property
    def lag(self) -> float:
        return self._lag

    def describe(self) -> dict[str, Any]:
        return dict(self.settings)
