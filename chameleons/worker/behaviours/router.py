"""The behaviour router: feeds participant frames to the current behaviour, samples it, and
switches behaviours with a linear crossfade so the output never jumps."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from chameleons.worker.behaviours.base import (
    VECTOR_SIZE,
    Behaviour,
    BehaviourContext,
)
from chameleons.worker.behaviours.history import ClockMapper, FrameHistory
from chameleons.worker.behaviours.neutral import DEFAULT_CALIBRATION_S, HeadNeutral
from chameleons.worker.behaviours.registry import create_behaviour
from chameleons.worker.frames import F32Array, FaceFrame

DEFAULT_HISTORY_SECONDS = 12.0
DEFAULT_MAX_INPUT_RATE = 120.0


class Crossfade(Behaviour):
    """``old`` fading linearly into ``new`` over ``[start, start + duration]``.

    Linear, so during the fade the output moves per tick by at most the two behaviours' own
    movement plus ``|new - old| * tick / duration``. Nested crossfades (a switch during a
    switch) compose.
    """

    name = "crossfade"

    def __init__(self, old: Behaviour, new: Behaviour, start: float, duration: float) -> None:
        super().__init__(new.context)
        self.old, self.new = old, new
        self.start_time, self.end_time = start, start + duration
        self._other = np.zeros(VECTOR_SIZE, dtype=np.float32)

    def on_participant(self, frame: FaceFrame, t: float) -> None:
        self.old.on_participant(frame, t)
        self.new.on_participant(frame, t)

    def sample(self, t: float, out: F32Array) -> float:
        if t >= self.end_time:
            return self.new.sample(t, out)
        if t <= self.start_time:
            return self.old.sample(t, out)
        w = np.float32((t - self.start_time) / (self.end_time - self.start_time))
        used_old = self.old.sample(t, self._other)
        used_new = self.new.sample(t, out)
        out *= w
        self._other *= 1 - w
        out += self._other
        return max(used_old, used_new) if not math.isnan(used_old + used_new) else used_new

    @property
    def lag(self) -> float:
        return self.new.lag


def build_context(
    history_seconds: float = DEFAULT_HISTORY_SECONDS,
    max_input_rate: float = DEFAULT_MAX_INPUT_RATE,
    locations: Any = None,
    rotation_factor: float | None = None,
    recentre_head: bool = True,
    head_calibration_s: float = DEFAULT_CALIBRATION_S,
    input_mirrored: bool = True,
) -> BehaviourContext:
    capacity = math.ceil(history_seconds * max_input_rate)
    return BehaviourContext(FrameHistory(capacity), history_seconds=history_seconds,
                            locations=locations, rotation_factor=rotation_factor,
                            head_neutral=HeadNeutral(head_calibration_s),
                            recentre_head=recentre_head,
                            input_mirrored=input_mirrored)  # fmt: skip


# Sources whose capture times are already on this host's clock: the worker's own camera
# (stamped on arrival, before tracking) and the capture page (mapped by the server relay
# and the browser receiver). The clock mapper would add their least tracking time to the
# copy delay (bench.webcam_bench measured +5 ms for the Python tracker).
LOCAL_CLOCK_SOURCES = frozenset({"webcam-python", "webcam-browser"})


class BehaviourRouter:
    """Owns the current behaviour, the participant history and the capture clock mapping."""

    def __init__(
        self, context: BehaviourContext, crossfade_seconds: float = 0.3, *,
        initial: str = "still", params: Mapping[str, Any] | None = None, start: float = 0.0,
    ) -> None:  # fmt: skip
        self.context = context
        self.crossfade_seconds = crossfade_seconds
        self.clock = ClockMapper()
        self.current: Behaviour = create_behaviour(initial, params or {}, context)
        self.current.start(start)
        self.current_name = initial
        self.current_params: dict[str, Any] = dict(params or {})
        self.frames_in = 0

    def on_participant(self, frame: FaceFrame) -> float:
        """Store a participant frame; returns its capture time on the local clock."""
        if frame.source in LOCAL_CLOCK_SOURCES:
            t = frame.capture_time
        else:
            t = self.clock.to_local(frame.capture_time, frame.receive_time)
        if self.context.history.append(t, frame.to_vector()):
            self.frames_in += 1
            self.context.head_neutral.add(t, frame.head)
            self.current.on_participant(frame, t)
        return t

    def set_behaviour(self, name: str, params: Mapping[str, Any], t: float) -> Behaviour:
        """Switch at local time ``t`` (the first sample time not yet published).
        Raises BehaviourError, leaving the current behaviour untouched, on bad input."""
        new = create_behaviour(name, params, self.context)
        new.start(t)
        if self.crossfade_seconds > 0:
            self.current = Crossfade(self.current, new, t, self.crossfade_seconds)
        else:
            self.current = new
        self.current_name, self.current_params = name, dict(params)
        return new

    def sample(self, t: float, out: F32Array) -> float:
        return self.current.sample(t, out)

    def realised(self) -> list[dict[str, Any]]:
        """The newest behaviour's draws since the last call (one being faded out reports
        nothing more: what it still draws is on its way out)."""
        newest = self.current
        while isinstance(newest, Crossfade):
            newest.old.realised()
            newest = newest.new
        return newest.realised()

    def advance(self, t: float) -> None:
        """No sample before ``t`` will be asked for again: drop finished crossfades."""
        current = self.current
        while isinstance(current, Crossfade) and t >= current.end_time:
            current = current.new
        self.current = current
