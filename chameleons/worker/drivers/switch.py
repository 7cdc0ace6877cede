"""``virtual+furhat``: one booth with both robots, the virtual display and a Furhat, for a
study whose embodiment varies within the session (the ``embodiment`` template).

The condition's ``renderer`` says which robot it runs on: ``2d`` or ``3d`` the display's
face, ``furhat`` the Furhat (the server sends it with the face in ``set_face``). Only that
robot is driven: the face and head frames, the prompts' audio or typed speech go to it. On
a switch the other robot is first set to its neutral face and head, so it never stays
frozen mid-expression, and audio it was playing stops.

The robot switched to wakes from that neutral: it is held there for ``hold_seconds``, then
faded linearly into the frames it is sent over ``fade_seconds``. A switch comes with the
new condition's behaviour, which the behaviour stage crossfades from the old one over its
``crossfade_seconds`` (and the renderer runs a few ticks ahead of the robot): without the
hold, the robot switched to showed the tail of the *other* robot's behaviour: a booth
check that had run a copy on the Furhat swung the display's head 15-18 deg as it put the
booth back (tests/backend/booth/test_booth_check_embodiment.py). The hold covers that tail
whichever of the two commands comes first (the server sends the behaviour first; the
bridge's replay after a reconnect, the face first). Both connect at the start; their
events (speech, connection state) reach the worker tagged with ``output``, and the worker's
robot state is the driven robot's (a switch to a robot in another state reports it).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np

from chameleons.worker.drivers.base import ROBOT_STATE, Driver, DriverEvent, EventSink
from chameleons.worker.frames import F32Array

FURHAT = "furhat"
HOLD_MARGIN_SECONDS = 0.1  # for the two commands' hops


def hold_seconds_for(crossfade_seconds: float, lookahead_seconds: float) -> float:
    """How long the robot switched to stays at its neutral: until the behaviour crossfade
    that comes with a switch has reached it (the crossfade, and the lookahead the behaviour
    stage samples ahead of the renderer), plus a margin."""
    return crossfade_seconds + lookahead_seconds + HOLD_MARGIN_SECONDS


# The worker's defaults: its 0.3 s behaviour crossfade, 5 ticks of lookahead at 125 Hz.
DEFAULT_FADE_SECONDS = 0.3
DEFAULT_HOLD_SECONDS = hold_seconds_for(DEFAULT_FADE_SECONDS, 5 / 125)


class SwitchDriver(Driver):
    name = "virtual+furhat"
    speaks_text: ClassVar[bool] = True  # the Furhat's TTS; on the display typed text is skipped

    def __init__(
        self, display: Driver, furhat: Driver, *, hold_seconds: float = DEFAULT_HOLD_SECONDS,
        fade_seconds: float = DEFAULT_FADE_SECONDS, clock: Callable[[], float] = time.monotonic,
    ) -> None:  # fmt: skip
        super().__init__()
        self.outputs = {"display": display, FURHAT: furhat}
        self.active_name = "display"
        self.hold_seconds, self.fade_seconds = hold_seconds, fade_seconds
        self._clock = clock
        self._switched_at: float | None = None  # while the robot switched to wakes

    @property
    def active(self) -> Driver:
        return self.outputs[self.active_name]

    def bind_events(self, sink: EventSink) -> None:
        super().bind_events(sink)
        for name, driver in self.outputs.items():
            driver.bind_events(lambda event, name=name: self._event(name, event))  # type: ignore[misc]

    def _event(self, output: str, event: DriverEvent) -> None:
        body = {**event.body, "output": output}
        if event.kind == ROBOT_STATE:
            if output != self.active_name:
                return  # the robot not driven now: its state shows in stats, not as ours
            self.state = str(event.body.get("state", self.state))
        self._sink(DriverEvent(event.kind, event.time, body))

    def start(self) -> None:
        for driver in self.outputs.values():
            driver.start()
        self.set_state(self.active.state, output=self.active_name)

    def close(self) -> None:
        for driver in self.outputs.values():
            driver.close()
        self.set_state("closed")

    def send_face(self, blendshapes: F32Array) -> None:
        self.faces_sent += 1
        weight = self._wake_weight()
        self.active.send_face(blendshapes if weight == 1.0 else blendshapes * np.float32(weight))

    def send_head(self, yaw: float, pitch: float, roll: float) -> None:
        self.heads_sent += 1
        weight = self._wake_weight()
        self.active.send_head(yaw * weight, pitch * weight, roll * weight)

    def shown_weight(self) -> float:
        """0 (its neutral, which is all zeros) through the hold after a switch, rising
        linearly to 1 over the fade."""
        if self._switched_at is None:
            return 1.0
        into_fade = self._clock() - self._switched_at - self.hold_seconds
        if into_fade < 0.0:
            return 0.0
        return 1.0 if into_fade >= self.fade_seconds else into_fade / self.fade_seconds

    def _wake_weight(self) -> float:
        weight = self.shown_weight()
        if weight == 1.0:
            self._switched_at = None  # awake: no clock read per frame from now on
        return weight

    def play_audio(self, prompt_id: str, url: str, play_id: str | None = None) -> None:
        self.active.play_audio(prompt_id, url, play_id)

    def speak_text(
        self, prompt_id: str, text: str, voice: str | None, play_id: str | None = None
    ) -> None:
        self.active.speak_text(prompt_id, text, voice, play_id)

    def stop_audio(self) -> None:
        self.active.stop_audio()

    def set_face(self, face_id: str, renderer: str | None = None) -> None:
        """``renderer`` furhat: drive the Furhat; 2d, 3d or None: the display."""
        chosen = FURHAT if renderer == FURHAT else "display"
        if chosen != self.active_name:
            previous = self.active
            previous.stop_audio()
            previous.rest()
            self.active_name = chosen
            self._switched_at = self._clock()
            self.set_state(self.active.state, output=chosen)
        if chosen == FURHAT:
            self.active.set_face(face_id)
        else:
            self.active.set_face(face_id, renderer)

    def remote_speech(self, event: str, prompt_id: str | None, play_id: str | None = None) -> None:
        self.outputs["display"].remote_speech(event, prompt_id, play_id)

    def retry(self) -> None:
        self.outputs[FURHAT].retry()

    def stats(self) -> dict[str, Any]:
        return {**self.active.stats(), "faces_sent": self.faces_sent,
                "heads_sent": self.heads_sent, "active": self.active_name,
                "outputs": {name: d.stats() for name, d in self.outputs.items()}}  # fmt: skip
