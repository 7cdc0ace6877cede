"""What a behaviour is: a module that turns participant frames into agent frames.

A behaviour is sampled, not pushed: the behaviour stage asks it for the agent's face at a
local time ``t`` (``time.monotonic()`` clock, possibly a few ticks in the future) and the
behaviour writes a face vector (:data:`VECTOR_SIZE` float32 values in
:meth:`FaceFrame.to_vector` layout: 52 blendshapes, head yaw/pitch/roll in degrees, six eye
rotations) into a buffer it is given. Participant frames arrive through
:meth:`Behaviour.on_participant` and are also kept, already on the local clock, in the
shared :class:`~chameleons.worker.behaviours.history.FrameHistory` of the context.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from chameleons.worker.behaviours.history import FrameHistory
from chameleons.worker.behaviours.neutral import HeadNeutral
from chameleons.worker.behaviours.params import Param
from chameleons.worker.frames import N_BLENDSHAPES, F32Array, FaceFrame

VECTOR_SIZE = FaceFrame.VECTOR_SIZE
HEAD_SLICE = slice(N_BLENDSHAPES, N_BLENDSHAPES + 3)
NO_INPUT = math.nan  # input time of a sample that no participant frame fed


class BehaviourError(ValueError):
    """A behaviour that cannot be created: unknown name or bad parameters."""


def neutral_vector() -> F32Array:
    return np.zeros(VECTOR_SIZE, dtype=np.float32)


@dataclass(slots=True)
class BehaviourContext:
    """What every behaviour may use: the participant's recent frames and the neutral face."""

    history: FrameHistory
    neutral: F32Array = field(default_factory=neutral_vector)
    history_seconds: float = 12.0  # how far back the history reaches at the nominal input rate
    # This machine's folders (``data_dir``, ``prompts_dir``) for marked paths such as
    # ``prompts:_natural/demo-natural.npz``; see chameleons.prompts.locations.
    locations: Any = None
    # Degrees per unit of a Live Link take CSV's rotations (the livelink_rotation_scale
    # setting), for clips read from takes; None: the take reader's default.
    rotation_factor: float | None = None
    # The participant's neutral head pose and whether ``copy`` re-centres the head on it
    # (the booth's ``head_recentre`` setting; :mod:`chameleons.worker.behaviours.neutral`).
    head_neutral: HeadNeutral = field(default_factory=HeadNeutral)
    recentre_head: bool = True
    # Whether the booth's capture already mirrors the participant (the ``mirror`` setting):
    # a ``copy`` condition's own ``mirror`` flips its output only where it differs.
    input_mirrored: bool = True


class Behaviour(ABC):
    """Base class of behaviour modules. Register subclasses with ``@register_behaviour``."""

    name: ClassVar[str] = ""
    # What a study may set in a condition's ``params`` (checked when the study is loaded,
    # defaults filled in; see :mod:`chameleons.worker.behaviours.params`). A behaviour
    # that declares none takes none.
    parameters: ClassVar[Mapping[str, Param]] = {}

    def __init__(self, context: BehaviourContext) -> None:
        self.context = context

    @classmethod
    def from_params(cls, context: BehaviourContext, params: Mapping[str, Any]) -> Behaviour:
        """Build from a command's JSON parameters; override when the behaviour takes any."""
        if params:
            raise BehaviourError(f"{cls.name} takes no parameters, got {sorted(params)}")
        return cls(context)

    def start(self, t: float) -> None:  # noqa: B027 - optional hook
        """Called once when the behaviour starts, with the first local time it will serve."""

    def on_participant(self, frame: FaceFrame, t: float) -> None:  # noqa: B027 - optional hook
        """A participant frame captured at local time ``t`` (already in the history)."""

    @abstractmethod
    def sample(self, t: float, out: F32Array) -> float:
        """Write the agent face for local time ``t`` into ``out``; return the local capture
        time of the newest participant input it used, or :data:`NO_INPUT`."""

    def describe(self) -> dict[str, Any]:
        """Parameters for status reports."""
        return {}

    def realised(self) -> list[dict[str, Any]]:
        """What the behaviour drew at random and has started to show since the last call
        (``copy``: its bouts and jittered delays); most behaviours draw nothing."""
        return []

    @property
    def lag(self) -> float:
        """Seconds by which this behaviour means its output to trail the input it used
        (``copy``: its delay). The worker's capture-to-send latency leaves it out."""
        return 0.0


def number_param(
    params: Mapping[str, Any], name: str, default: float, *, low: float, high: float
) -> float:
    """Read a finite number parameter within ``[low, high]`` or raise BehaviourError."""
    value = params.get(name, default)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise BehaviourError(f"{name} must be a number, got {value!r}")
    if not low <= value <= high:
        raise BehaviourError(f"{name} must be within {low}..{high}, got {value}")
    return float(value)


def reject_unknown(params: Mapping[str, Any], known: set[str]) -> None:
    unknown = sorted(set(params) - known)
    if unknown:
        raise BehaviourError(f"unknown parameters: {', '.join(unknown)}")
