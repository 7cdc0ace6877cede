"""Recorded face motion for ``natural``: times plus face vectors, and loaders for it."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from chameleons.worker.behaviours.base import VECTOR_SIZE, BehaviourError
from chameleons.worker.frames import N_BLENDSHAPES, F32Array

F64Array = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class MotionClip:
    """``times`` (seconds from 0, strictly increasing) and ``vectors`` (N x 61 face vectors:
    52 blendshapes, head yaw/pitch/roll in degrees, 6 eye rotations)."""

    times: F64Array
    vectors: F32Array

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    @classmethod
    def from_arrays(
        cls,
        times: npt.ArrayLike,
        blendshapes: npt.ArrayLike,
        head: npt.ArrayLike | None = None,
        eyes: npt.ArrayLike | None = None,
    ) -> MotionClip:
        t = np.asarray(times, dtype=np.float64).reshape(-1)
        n = len(t)
        shapes = np.asarray(blendshapes, dtype=np.float32)
        if shapes.shape != (n, N_BLENDSHAPES):
            raise BehaviourError(f"blendshapes must be {n} x {N_BLENDSHAPES}, got {shapes.shape}")
        vectors = np.zeros((n, VECTOR_SIZE), dtype=np.float32)
        vectors[:, :N_BLENDSHAPES] = np.clip(shapes, 0.0, 1.0)
        for start, width, part in ((N_BLENDSHAPES, 3, head), (N_BLENDSHAPES + 3, 6, eyes)):
            if part is not None:
                vectors[:, start : start + width] = np.asarray(part, np.float32).reshape(n, width)
        if n < 2 or not np.all(np.isfinite(t)) or not np.all(np.diff(t) > 0):
            raise BehaviourError("a motion clip needs >= 2 frames with increasing finite times")
        if not np.all(np.isfinite(vectors)):
            raise BehaviourError("a motion clip must not contain NaN or infinite values")
        return cls(t - t[0], vectors)

    def sample(self, u: float, out: F32Array) -> None:
        """Linear interpolation at clip time ``u`` (clamped to the clip) into ``out``."""
        times = self.times
        i = int(np.searchsorted(times, u, side="right"))
        if i <= 0:
            out[:] = self.vectors[0]
        elif i >= len(times):
            out[:] = self.vectors[-1]
        else:
            w = (u - times[i - 1]) / (times[i] - times[i - 1])
            np.subtract(self.vectors[i], self.vectors[i - 1], out=out)
            out *= np.float32(w)
            out += self.vectors[i - 1]


def load_clip(path: str | Path, *, rotation_factor: float | None = None) -> MotionClip:
    """A clip from a Live Link take CSV, a face-stream recording (Parquet) or an ``.npz``
    with arrays ``times``, ``blendshapes`` and optionally ``head``, ``eyes``. A take's
    rotations are read with ``rotation_factor`` (degrees per unit: the worker's
    ``livelink_rotation_scale``; None: the take reader's default)."""
    path = Path(path)
    if not path.is_file():
        raise BehaviourError(f"motion recording not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".npz":
        with np.load(path) as data:
            if "times" not in data or "blendshapes" not in data:
                raise BehaviourError(f"{path}: an .npz clip needs 'times' and 'blendshapes'")
            return MotionClip.from_arrays(
                data["times"], data["blendshapes"], data.get("head"), data.get("eyes")
            )
    if suffix == ".csv":
        return _load_take(path, rotation_factor)
    if suffix == ".parquet":
        return _load_recording(path)
    raise BehaviourError(f"{path}: unsupported motion recording type {suffix!r}")


def _load_take(path: Path, rotation_factor: float | None) -> MotionClip:
    from chameleons.worker.takes import TakeError, read_take

    try:
        take = read_take(path) if rotation_factor is None else read_take(
            path, rotation_factor=rotation_factor)  # fmt: skip
    except TakeError as exc:
        raise BehaviourError(str(exc)) from exc
    return MotionClip.from_arrays(take.times, take.blendshapes, take.head, take.eyes)


def _load_recording(path: Path) -> MotionClip:
    from chameleons.worker.recording import RecordingError, read_recording

    try:
        take = read_recording(path)
    except RecordingError as exc:
        raise BehaviourError(str(exc)) from exc
    return MotionClip.from_arrays(take.times, take.blendshapes, take.head, take.eyes)
