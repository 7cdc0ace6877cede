"""What the renderer drives: a robot face (or a stand-in).

All methods are called from the renderer's tick thread only and must return at once (a
driver that talks to a device queues and sends from its own thread). A driver reports what
happens on its side (speech started/ended, connection state) through the event sink the
renderer gives it; the sink is thread-safe.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from chameleons.worker.frames import N_BLENDSHAPES, F32Array

SPEECH_START = "speech_start"
SPEECH_END = "speech_end"
ROBOT_STATE = "robot_state"


@dataclass(frozen=True, slots=True)
class DriverEvent:
    kind: str  # SPEECH_START, SPEECH_END or ROBOT_STATE
    time: float  # worker clock (time.monotonic())
    body: dict[str, Any] = field(default_factory=dict)


EventSink = Callable[[DriverEvent], None]


def _discard(_event: DriverEvent) -> None:
    return None


class Driver(ABC):
    name: ClassVar[str] = ""
    # False: the robot never says when audio ends; the renderer ends speech with the curves.
    reports_speech_end: ClassVar[bool] = True
    # True: the robot speaks text with its own TTS (:meth:`speak_text`, typed speech).
    speaks_text: ClassVar[bool] = False

    def __init__(self) -> None:
        self._sink: EventSink = _discard
        self.state = "disconnected"
        self.faces_sent = 0
        self.heads_sent = 0

    def bind_events(self, sink: EventSink) -> None:
        self._sink = sink

    def emit(self, kind: str, **body: Any) -> None:
        self._sink(DriverEvent(kind, time.monotonic(), body))

    def set_state(self, state: str, **detail: Any) -> None:
        if state != self.state:
            self.state = state
            self.emit(ROBOT_STATE, state=state, **detail)

    @property
    def connected(self) -> bool:
        return self.state == "connected"

    def start(self) -> None:
        """Open connections/files; called once before the first tick."""
        self.set_state("connected")

    def close(self) -> None:
        """Release everything; called once after the last tick."""
        self.set_state("closed")

    @abstractmethod
    def send_face(self, blendshapes: F32Array) -> None:
        """52 blendshape values in canonical order (0..1)."""

    @abstractmethod
    def send_head(self, yaw: float, pitch: float, roll: float) -> None:
        """Absolute head pose in degrees."""

    def shown_weight(self) -> float:
        """How much of the frames it is sent the robot shows now: 1, except while a robot
        switched to wakes from its neutral (``drivers.switch``). The renderer scales its
        record of what was sent (``face.sent``, the recordings') by it."""
        return 1.0

    def rest(self) -> None:
        """Set the robot to its neutral face and head now (another robot takes over)."""
        self.send_face(np.zeros(N_BLENDSHAPES, dtype=np.float32))
        self.send_head(0.0, 0.0, 0.0)

    def play_audio(self, prompt_id: str, url: str, play_id: str | None = None) -> None:
        """Start the prompt's audio; speech start/end come back as events, carrying
        ``play_id`` (this play's own id: the same prompt may be played twice)."""
        self.emit(SPEECH_START, prompt_id=prompt_id, play_id=play_id)

    def speak_text(
        self, prompt_id: str, text: str, voice: str | None, play_id: str | None = None
    ) -> None:
        """Say ``text`` with the robot's own TTS (``voice``, or its current one); speech
        start/end come back as events carrying ``play_id``. Only drivers with
        ``speaks_text`` get this (the worker refuses typed text for the others), so here it
        ends unvoiced at once."""
        self.emit(SPEECH_END, prompt_id=prompt_id, play_id=play_id, outcome="skipped",
                  error=f"the {self.name or 'robot'} driver has no text-to-speech")  # fmt: skip

    def stop_audio(self) -> None:  # noqa: B027 - optional
        """Stop the audio that is playing, if any."""

    def set_face(self, face_id: str, renderer: str | None = None) -> None:  # noqa: B027 - optional
        """Select the robot's face (character/mask); ``renderer`` (2d|3d) is for the virtual
        robot's display and ignored by physical robots."""

    def retry(self) -> None:  # noqa: B027 - optional
        """Try the robot again after the driver stopped itself (a refused login)."""

    def remote_speech(  # noqa: B027
        self, event: str, prompt_id: str | None, play_id: str | None = None
    ) -> None:
        """Speech start/end reported by the server (the virtual robot's page)."""

    def stats(self) -> dict[str, Any]:
        return {"state": self.state, "faces_sent": self.faces_sent,
                "heads_sent": self.heads_sent}  # fmt: skip
