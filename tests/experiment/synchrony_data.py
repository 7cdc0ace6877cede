"""Synthetic face streams for the synchrony tests: smooth random movement (head in
degrees, blendshapes 0..1) at a capture rate with timing jitter, and a robot that copies
it with a delay at its own send rate, as the worker records them."""

from __future__ import annotations

import numpy as np

from chameleons.experiment.stats.synchrony import FaceStream

CHANNELS = ("head_yaw", "head_pitch", "head_roll", "browInnerUp", "eyeBlinkLeft",
            "cheekSquintLeft", "mouthSmileLeft", "jawOpen")  # fmt: skip


def smooth_face(seed: int, duration: float, fps: float = 60.0, jitter: float = 0.003,
                channels: tuple[str, ...] = CHANNELS) -> FaceStream:  # fmt: skip
    """Band-limited random movement (a Gaussian-smoothed random walk of steps), jittered
    frame times."""
    rng = np.random.default_rng(seed)
    times = np.arange(0.0, duration, 1.0 / fps)
    times = times + rng.uniform(0.0, jitter, len(times))
    kernel = np.exp(-0.5 * (np.arange(-90, 91) / 18.0) ** 2)
    kernel /= kernel.sum()
    values = np.empty((len(times), len(channels)))
    for column, name in enumerate(channels):
        smooth = np.convolve(rng.standard_normal(len(times)), kernel, mode="same")
        values[:, column] = smooth * 40.0 if name.startswith("head_") else 0.3 + smooth * 2.0
    return FaceStream.of(times, values, channels)


def delayed(source: FaceStream, delay: float, fps: float = 125.0, noise: float = 0.0,
            seed: int = 0) -> FaceStream:  # fmt: skip
    """A robot emitting ``source`` as it was ``delay`` seconds earlier (interpolated),
    sending at ``fps`` from the source's start; plus measurement noise if asked."""
    rng = np.random.default_rng(seed)
    times = np.arange(source.start, source.end + delay, 1.0 / fps)
    values = np.column_stack([
        np.interp(times - delay, source.times, source.values[:, k])
        for k in range(len(source.channels))
    ])  # fmt: skip
    values += noise * rng.standard_normal(values.shape)
    return FaceStream.of(times, values, source.channels)


def still(source: FaceStream, fps: float = 125.0, noise: float = 0.0, seed: int = 0
          ) -> FaceStream:  # fmt: skip
    """A robot that holds its neutral face (plus sensor-like noise if asked)."""
    rng = np.random.default_rng(seed)
    times = np.arange(source.start, source.end, 1.0 / fps)
    values = noise * rng.standard_normal((len(times), len(source.channels)))
    return FaceStream.of(times, values, source.channels)


def drop(stream: FaceStream, start: float, end: float) -> FaceStream:
    """The stream without its frames between ``start`` and ``end`` (a capture gap)."""
    keep = (stream.times < start) | (stream.times > end)
    return FaceStream(stream.times[keep], stream.values[keep], stream.channels)
