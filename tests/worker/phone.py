"""A simulated phone for end-to-end tests: the capture side's Live Link sender, fed a face
that steps between poses at known times, each send time recorded. Not a test module."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES
from chameleons.worker.simulate import FaceSample, LiveLinkSender, run_simulation


@dataclass(frozen=True)
class Pose:
    yaw: float
    pitch: float
    jaw_open: float


@dataclass
class SteppingPhone:
    """Sends ``poses[i]`` from ``times[i]`` seconds after start, at ``fps``, until stopped."""

    port: int
    poses: list[Pose]
    times: list[float]
    fps: float = 60.0
    sent_at: dict[int, float] = field(default_factory=dict)  # pose index -> first send time
    stop: threading.Event = field(default_factory=threading.Event)

    def __post_init__(self) -> None:
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _samples(self) -> Iterator[FaceSample]:
        k = 0
        while True:
            t = k / self.fps
            index = max(i for i, start in enumerate(self.times) if start <= t)
            pose = self.poses[index]
            shapes = np.zeros(N_BLENDSHAPES, dtype=np.float32)
            shapes[BLENDSHAPE_INDEX["jawOpen"]] = pose.jaw_open
            head = np.array([pose.yaw, pose.pitch, 0.0], dtype=np.float32)
            yield FaceSample(t, shapes, head, np.zeros(6, dtype=np.float32))
            k += 1

    def _run(self) -> None:
        phone = self

        class Recording(LiveLinkSender):
            def send(self, sample: FaceSample) -> None:
                super().send(sample)
                index = max(i for i, start in enumerate(phone.times) if start <= sample.time)
                phone.sent_at.setdefault(index, time.monotonic())

        run_simulation(Recording("127.0.0.1", self.port, fps=self.fps), self._samples(),
                       stop=self.stop)  # fmt: skip

    def __enter__(self) -> SteppingPhone:
        self._thread.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.stop.set()
        self._thread.join(5)
