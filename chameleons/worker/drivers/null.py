"""``null``: accepts everything and sends nowhere (benchmarks, a worker without a robot)."""

from __future__ import annotations

from typing import ClassVar

from chameleons.worker.drivers.base import Driver
from chameleons.worker.frames import F32Array


class NullDriver(Driver):
    name = "null"
    reports_speech_end: ClassVar[bool] = False

    def send_face(self, blendshapes: F32Array) -> None:
        self.faces_sent += 1

    def send_head(self, yaw: float, pitch: float, roll: float) -> None:
        self.heads_sent += 1
