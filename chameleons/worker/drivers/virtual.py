"""``virtual``: frames for the built-in virtual robot, a browser page the server serves.

Every call becomes an envelope on topic ``display.<booth>`` published through the worker's
PUB connection to the server, which relays it to the booth's robot display page:

- ``face``: payload 52 float32 blendshapes in canonical order (``frames.BLENDSHAPE_NAMES``);
- ``head``: body ``{"yaw", "pitch", "roll"}`` in degrees, at most ``head_rate`` per second
  (the page draws at display rate; more would only load the relay);
- ``play_audio`` ``{"prompt_id", "url", "play_id"}``, ``stop_audio``, ``set_face``
  ``{"face_id", "renderer"?}``. The page reports speech start/end with the play's ``play_id``.

The page reports when the audio really starts and ends; the server sends those back as
``speech_event`` commands, which reach :meth:`VirtualDriver.remote_speech`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from chameleons.worker.control import display_topic
from chameleons.worker.drivers.base import SPEECH_END, SPEECH_START, Driver
from chameleons.worker.envelope import Message
from chameleons.worker.frames import F32Array

Publish = Callable[[Message], None]


class VirtualDriver(Driver):
    name = "virtual"

    def __init__(self, booth: str, publish: Publish, *, head_rate: float = 60.0) -> None:
        super().__init__()
        self.topic = display_topic(booth)
        self.booth = booth
        self._publish = publish
        self._head_interval = 1.0 / head_rate
        self._next_head = 0.0
        self._seq = 0

    def _send(self, kind: str, body: dict[str, Any] | None = None, payload: bytes = b"") -> None:
        self._seq += 1
        now = time.monotonic()
        self._publish(Message(self.topic, kind, self._seq, self.booth, now, body or {}, payload))

    def send_face(self, blendshapes: F32Array) -> None:
        self.faces_sent += 1
        self._send("face", payload=blendshapes.astype(np.dtype("<f4")).tobytes())

    def send_head(self, yaw: float, pitch: float, roll: float) -> None:
        now = time.monotonic()
        if now < self._next_head:
            return
        self._next_head = max(self._next_head + self._head_interval, now - self._head_interval)
        self.heads_sent += 1
        self._send("head", {"yaw": yaw, "pitch": pitch, "roll": roll})

    def rest(self) -> None:
        self._next_head = 0.0  # the neutral head is never dropped by the head rate
        super().rest()

    def play_audio(self, prompt_id: str, url: str, play_id: str | None = None) -> None:
        body = {"prompt_id": prompt_id, "url": url}
        if play_id:
            body["play_id"] = play_id
        self._send("play_audio", body)

    def stop_audio(self) -> None:
        self._send("stop_audio")

    def set_face(self, face_id: str, renderer: str | None = None) -> None:
        body = {"face_id": face_id}
        if renderer:
            body["renderer"] = renderer
        self._send("set_face", body)

    def remote_speech(self, event: str, prompt_id: str | None, play_id: str | None = None) -> None:
        self.emit(SPEECH_START if event == "start" else SPEECH_END, prompt_id=prompt_id,
                  play_id=play_id)  # fmt: skip
