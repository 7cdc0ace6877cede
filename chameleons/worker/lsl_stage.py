"""The LSL stage (``chameleons worker --lsl``): the participant's face and the robot's
rendered face as LSL ``Face`` streams (:mod:`chameleons.instruments.lsl`).

It listens where the recorder does: the participant bus (``face.participant``, every
captured frame at the source's own rate, stamped with its capture time) and the renderer
(``face.sent``, the face computed on each tick, at the tick rate, stamped with the time it
was due). Both times are this host's ``time.monotonic()``, mapped onto LSL's clock. A frame
it cannot read is counted and dropped; LSL never blocks the pipeline (an outlet without
inlets drops samples itself).
"""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from typing import Any

import numpy as np
import zmq

from chameleons.instruments.lsl import LslClock, face_outlet
from chameleons.worker.envelope import EnvelopeError, Message, message_frame
from chameleons.worker.frames import FaceFrame
from chameleons.worker.stage import (
    PARTICIPANT_TOPIC,
    POLL_MS,
    SENT_TOPIC,
    Endpoints,
    receive_messages,
)

log = logging.getLogger(__name__)
# The participant's rate is the source's (an iPhone sends 60 fps, a webcam what it can):
# declared irregular, so no reader resamples it onto a grid it never kept.
PARTICIPANT_RATE = 0.0


class LslStage:
    name = "lsl"

    def __init__(self, context: zmq.Context[zmq.Socket[bytes]], endpoints: Endpoints, *,
                 booth: str, tick_rate: float) -> None:  # fmt: skip
        self.context, self.endpoints = context, endpoints
        self.booth, self.tick_rate = booth, tick_rate
        self.clock = LslClock()
        self.errors: Counter[str] = Counter()
        self.pushed: Counter[str] = Counter()
        self.outlets: dict[str, Any] = {}
        self.ready = threading.Event()

    def open_outlets(self) -> None:
        source = f"chameleons-{self.booth}"
        self.outlets = {
            "participant": face_outlet(self.booth, "participant", PARTICIPANT_RATE,
                                       f"{source}-participant"),
            "robot": face_outlet(self.booth, "robot", self.tick_rate, f"{source}-robot"),
        }  # fmt: skip

    def run(self, stop: threading.Event) -> None:
        sub = self.context.socket(zmq.SUB)
        sub.setsockopt(zmq.LINGER, 0)
        for topic in (PARTICIPANT_TOPIC, SENT_TOPIC):
            sub.setsockopt(zmq.SUBSCRIBE, topic.encode())
        sub.connect(self.endpoints.participant)
        sub.connect(self.endpoints.render)
        try:
            self.open_outlets()
            self.ready.set()
            while not stop.is_set():
                if sub.poll(POLL_MS):
                    for message in receive_messages(sub, self.errors):
                        self.push(message)
        finally:
            sub.close(linger=0)
            self.outlets = {}  # pylsl closes an outlet when it is collected

    def push(self, message: Message) -> None:
        try:
            if message.topic == PARTICIPANT_TOPIC:
                frame = message_frame(message)
                stream, vector, t = "participant", frame.recorded_vector(), frame.capture_time
            else:
                vector = message.array().astype(np.float32)
                if vector.shape != (FaceFrame.VECTOR_SIZE,):
                    raise ValueError("not a face vector")
                stream, t = "robot", float(message.body["t"])
        except (EnvelopeError, KeyError, TypeError, ValueError) as exc:
            self.errors[getattr(exc, "reason", "bad_frame")] += 1
            return
        outlet = self.outlets.get(stream)
        if outlet is None:
            return
        outlet.push_sample(vector.tolist(), self.clock.from_monotonic(t))
        self.pushed[stream] += 1

    def status(self) -> dict[str, Any]:
        return {"pushed": dict(self.pushed), "errors": dict(self.errors),
                "time": time.monotonic()}  # fmt: skip
