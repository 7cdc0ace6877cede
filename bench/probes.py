"""Measuring instruments for the worker benchmarks: a driver that timestamps what it sends,
a phone that sends a known triangle wave, and the triangle's inverse."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np

from chameleons.worker.drivers import Driver, Publish
from chameleons.worker.drivers.null import NullDriver
from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES, F32Array
from chameleons.worker.runtime import Worker, WorkerConfig
from chameleons.worker.simulate import FaceSample, LiveLinkSender, run_simulation

PERIOD = 8.0  # seconds of one triangle wave
AMPLITUDE = 40.0  # head yaw, degrees
JAW = BLENDSHAPE_INDEX["jawOpen"]
CORNER_MARGIN = 0.06  # fraction of a period around each corner left out (FIR, interpolation)


def triangle(u: float) -> float:
    """-1 at phase 0, +1 at phase 0.5, back to -1: slope 4 per period."""
    phase = (u / PERIOD) % 1.0
    return 4 * phase - 1 if phase < 0.5 else 3 - 4 * phase


def invert_triangle(value: float, near: float) -> float | None:
    """The time ``u`` close to ``near`` with ``triangle(u) == value``; None near a corner."""
    phase = (near / PERIOD) % 1.0
    if min(phase, abs(phase - 0.5), 1 - phase) < CORNER_MARGIN:
        return None
    rising = phase < 0.5
    found = (value + 1) / 4 if rising else (3 - value) / 4
    return math.floor(near / PERIOD) * PERIOD + found * PERIOD


class ProbeDriver(NullDriver):
    """Timestamps every head pose and face frame it is given (preallocated)."""

    name = "probe"

    def __init__(self, capacity: int = 1 << 17) -> None:
        super().__init__()
        self.head_times = np.zeros(capacity)
        self.head_yaw = np.zeros(capacity)
        self.face_times = np.zeros(capacity)
        self.face_jaw = np.zeros(capacity)

    def send_head(self, yaw: float, pitch: float, roll: float) -> None:
        i = self.heads_sent % len(self.head_times)
        self.head_times[i], self.head_yaw[i] = time.monotonic(), yaw
        self.heads_sent += 1

    def send_face(self, blendshapes: F32Array) -> None:
        i = self.faces_sent % len(self.face_times)
        self.face_times[i], self.face_jaw[i] = time.monotonic(), blendshapes[JAW]
        self.faces_sent += 1


class ProbeWorker(Worker):
    """A worker whose (in-process) renderer drives a :class:`ProbeDriver`."""

    def __init__(self, config: WorkerConfig) -> None:
        self.probe = ProbeDriver()
        super().__init__(config, driver_factory=self._probe_driver)

    def _probe_driver(self, publish: Publish) -> Driver:
        return self.probe


class TrianglePhone:
    """Live Link UDP at 60 fps: yaw = 40 deg x triangle, jawOpen = (triangle + 1) / 2."""

    def __init__(self, port: int, duration: float, fps: float = 60.0) -> None:
        self.port, self.duration, self.fps = port, duration, fps
        self.start = math.nan  # local monotonic time of the wave's u = 0
        self.stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _samples(self) -> Iterator[FaceSample]:
        for k in range(int(self.duration * self.fps)):
            u = k / self.fps
            shapes = np.zeros(N_BLENDSHAPES, dtype=np.float32)
            shapes[JAW] = (triangle(u) + 1) / 2
            head = np.array([AMPLITUDE * triangle(u), 0, 0], dtype=np.float32)
            yield FaceSample(u, shapes, head, np.zeros(6, dtype=np.float32))

    def _run(self) -> None:
        phone = self

        class Sender(LiveLinkSender):
            def send(self, sample: FaceSample) -> None:
                if math.isnan(phone.start):
                    phone.start = time.monotonic() - sample.time
                super().send(sample)

        run_simulation(Sender("127.0.0.1", self.port, fps=self.fps), self._samples(),
                       stop=self.stop)  # fmt: skip

    def __enter__(self) -> TrianglePhone:
        self._thread.start()
        return self

    def __exit__(self, *_exc: Any) -> None:
        self.stop.set()
        self._thread.join(5)


def delay_errors(times: np.ndarray, values: np.ndarray, start: float, delay: float) -> np.ndarray:
    """For each send (time, value of triangle in -1..1): realised delay minus ``delay``."""
    errors = []
    for sent, value in zip(times, values, strict=True):
        near = sent - start - delay
        if near < 0:
            continue
        u = invert_triangle(float(value), near)
        if u is not None:
            errors.append(sent - (start + u) - delay)
    return np.asarray(errors)
