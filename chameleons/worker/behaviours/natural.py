"""``natural``: replays recorded face motion (a Live Link take or another participant's
recorded stream — the yoked control), looping, starting at a chosen offset.

What a *study* sets (``parameters``) and what the *worker* gets differ: a study names the
source (``clip``: a recording in the prompt catalogue, the paper's "recording of facial
gestures from an unrelated conversation"; ``yoked``: another participant's recorded stream;
``synthetic``: the face simulator), and the server resolves it, per interaction, into the
worker's parameters below (see ``chameleons.backend.booth.service``).

The loop seam is crossfaded: with period ``P = duration - seam``, the first ``seam``
seconds of each pass blend the clip's tail into its head, so output is continuous.
Parameters: ``path`` (take CSV, Parquet recording or ``.npz``), ``offset`` seconds, ``loop``;
or, instead of ``path``, ``seed``: a synthetic face from the simulator (demos, tests).
A ``path`` may be marked ``prompts:...`` or ``data:...`` (from a server on another machine):
it is resolved against this worker's own prompts folder or data directory.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from chameleons.locations import resolve_marked_path
from chameleons.worker.behaviours.base import (
    NO_INPUT,
    VECTOR_SIZE,
    Behaviour,
    BehaviourContext,
    BehaviourError,
    number_param,
    reject_unknown,
)
from chameleons.worker.behaviours.clips import MotionClip, load_clip
from chameleons.worker.behaviours.params import Param
from chameleons.worker.behaviours.registry import register_behaviour
from chameleons.worker.frames import F32Array

MAX_SEAM = 0.5
SYNTHETIC_SECONDS = 60.0
SOURCES = ("clip", "yoked", "synthetic")
DEFAULT_CLIP = "demo-natural"


def synthetic_clip(seed: int = 0, seconds: float = SYNTHETIC_SECONDS) -> MotionClip:
    """A plausible face (blinks, head sway, smiles, talking) from the face simulator."""
    from chameleons.worker.simulate import SyntheticFace

    samples = list(SyntheticFace(seed).samples(30.0, seconds))
    return MotionClip.from_arrays(
        [s.time for s in samples], np.stack([s.blendshapes for s in samples]),
        np.stack([s.head for s in samples]), np.stack([s.eyes for s in samples]),
    )  # fmt: skip


@register_behaviour("natural")
class NaturalBehaviour(Behaviour):
    parameters = {
        "source": Param(
            "choice", "clip", "What is replayed: clip (one fixed recording, the paper), yoked "
            "(another participant's recorded face) or synthetic (the face simulator).",
            choices=SOURCES,
        ),
        "clip": Param(
            "text", DEFAULT_CLIP, "The recording for source clip, and for yoked until another "
            "participant has been recorded: a name in the prompts folder's _natural/ "
            "(demo-natural) or a path inside the prompts folder (m1/natural/conversation).",
        ),
        "yoked_min_seconds": Param(
            "number", 30.0, "Source yoked: the shortest recording of another participant "
            "that may be replayed.", minimum=0.0, maximum=3600.0,
        ),
        "seed": Param("integer", 0, "Source synthetic: which synthetic face.", minimum=0,
                      maximum=2**31 - 1),
        "offset": Param("number", 0.0, "Seconds into the recording to start at.", minimum=0.0,
                        maximum=1e6),
        "loop": Param("boolean", True, "Start over at the end of the recording."),
    }  # fmt: skip

    def __init__(
        self, context: BehaviourContext, clip: MotionClip, *, offset: float = 0.0,
        loop: bool = True, source: str = "",
    ) -> None:  # fmt: skip
        super().__init__(context)
        if not math.isfinite(offset) or offset < 0:
            raise BehaviourError(f"offset must be a non-negative number, got {offset}")
        self.clip = clip
        self.offset = offset
        self.loop = loop
        self.source = source
        self.seam = min(MAX_SEAM, clip.duration / 4)
        self._period = clip.duration - self.seam
        self._start = math.nan
        self._tail = np.zeros(VECTOR_SIZE, dtype=np.float32)

    @classmethod
    def from_params(cls, context: BehaviourContext, params: Mapping[str, Any]) -> Behaviour:
        reject_unknown(params, {"path", "offset", "loop", "seed"})
        loop = params.get("loop", True)
        if not isinstance(loop, bool):
            raise BehaviourError(f"loop must be true or false, got {loop!r}")
        offset = number_param(params, "offset", 0.0, low=0.0, high=1e6)
        path = params.get("path")
        if path is None and "seed" in params:  # asked for explicitly: a synthetic stand-in
            seed = int(number_param(params, "seed", 0, low=0, high=2**31))
            return cls(context, synthetic_clip(seed), offset=offset, loop=loop,
                       source=f"synthetic:{seed}")  # fmt: skip
        if not isinstance(path, str) or not path:
            # Never a silent stand-in: the yoked control must replay a real recording.
            raise BehaviourError("natural needs a 'path' to a take CSV, Parquet recording or "
                                 ".npz clip (or a 'seed' for a synthetic face)")  # fmt: skip
        local = resolve_marked_path(path, context.locations)  # "prompts:..." / "data:..."
        clip = load_clip(local, rotation_factor=context.rotation_factor)
        return cls(context, clip, offset=offset, loop=loop, source=path)

    def start(self, t: float) -> None:
        self._start = t

    def sample(self, t: float, out: F32Array) -> float:
        if math.isnan(self._start):
            self._start = t
        u = t - self._start + self.offset
        if not self.loop:
            self.clip.sample(u, out)
            return NO_INPUT
        phase = u % self._period
        self.clip.sample(phase, out)
        if phase < self.seam:  # blend in the tail of the previous pass
            self.clip.sample(phase + self._period, self._tail)
            w = np.float32(phase / self.seam)
            out *= w
            out += self._tail * (1 - w)
        return NO_INPUT

    def describe(self) -> dict[str, Any]:
        return {"offset": self.offset, "loop": self.loop, "source": self.source,
                "duration": self.clip.duration}  # fmt: skip
