"""Write a Live Link Face take CSV (protocols.md 2b), the app's 63 columns, for
``chameleons face-track``: what :func:`chameleons.worker.takes.read_take` and ``prompts
import`` read.

Columns in the app's order (it differs from the UDP order at the jaw and the mouth):
``Timecode, BlendShapeCount``, the 52 blendshapes in PascalCase, ``HeadYaw`` ..
``RightEyeRoll`` in radians. ``Timecode`` is ``HH:MM:SS:FF.fff``: the frame ``FF`` and its
fraction ``.fff`` count at a standard timecode base, the smallest of 24, 25, 30, 50, 60 at
or above the video's frame rate, so the take reader's base (read from the highest ``FF``)
gives back each frame's time exactly. A take has no way to say "missing": channels the
webcam cannot measure (cheekPuff, jawForward, tongueOut; the eyes' look without irises) are
written as 0, the face at rest.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from chameleons.worker.frames import BLENDSHAPE_INDEX, EYE_NAMES, HEAD_NAMES
from chameleons.worker.takes import TIMECODE_BASES

TAKE_BLENDSHAPES = (
    "EyeBlinkLeft", "EyeLookDownLeft", "EyeLookInLeft", "EyeLookOutLeft", "EyeLookUpLeft",
    "EyeSquintLeft", "EyeWideLeft", "EyeBlinkRight", "EyeLookDownRight", "EyeLookInRight",
    "EyeLookOutRight", "EyeLookUpRight", "EyeSquintRight", "EyeWideRight",
    "JawForward", "JawRight", "JawLeft", "JawOpen", "MouthClose", "MouthFunnel",
    "MouthPucker", "MouthRight", "MouthLeft", "MouthSmileLeft", "MouthSmileRight",
    "MouthFrownLeft", "MouthFrownRight", "MouthDimpleLeft", "MouthDimpleRight",
    "MouthStretchLeft", "MouthStretchRight", "MouthRollLower", "MouthRollUpper",
    "MouthShrugLower", "MouthShrugUpper", "MouthPressLeft", "MouthPressRight",
    "MouthLowerDownLeft", "MouthLowerDownRight", "MouthUpperUpLeft", "MouthUpperUpRight",
    "BrowDownLeft", "BrowDownRight", "BrowInnerUp", "BrowOuterUpLeft", "BrowOuterUpRight",
    "CheekPuff", "CheekSquintLeft", "CheekSquintRight", "NoseSneerLeft", "NoseSneerRight",
    "TongueOut",
)  # fmt: skip
HEADER = ("Timecode", "BlendShapeCount", *TAKE_BLENDSHAPES, *HEAD_NAMES, *EYE_NAMES)
_ORDER = [BLENDSHAPE_INDEX[name[0].lower() + name[1:]] for name in TAKE_BLENDSHAPES]


@dataclass(frozen=True, slots=True)
class TakeRow:
    time: float  # seconds from the video's start
    blendshapes: npt.NDArray[np.floating]  # 52, canonical order; NaN = missing
    head: tuple[float, float, float]  # yaw, pitch, roll (degrees)
    eyes: npt.NDArray[np.floating]  # 6, degrees


def timecode_base(frame_rate: float) -> float:
    """The smallest standard base at or above ``frame_rate`` (60 above them all)."""
    return next((b for b in TIMECODE_BASES if frame_rate <= b + 1e-6), TIMECODE_BASES[-1])


def timecode(seconds: float, base: float) -> str:
    """``HH:MM:SS:FF.fff`` of ``seconds`` from 00:00:00:00 at ``base`` frames a second."""
    frames = seconds * base
    whole = math.floor(frames + 1e-9)
    fraction = min(999, round((frames - whole) * 1000))
    second, ff = divmod(whole, round(base))
    hh, rest = divmod(second, 3600)
    mm, ss = divmod(rest, 60)
    return f"{hh:02d}:{mm:02d}:{ss:02d}:{ff:02d}.{fraction:03d}"


def write_take(path: str | Path, rows: Iterable[TakeRow], frame_rate: float) -> int:
    """Write the take (atomically: a temporary file renamed into place); returns the rows."""
    path = Path(path)
    base = timecode_base(frame_rate)
    partial = path.with_name(path.name + ".partial")
    count = 0
    try:
        with partial.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow(HEADER)
            for row in rows:
                shapes = np.nan_to_num(np.asarray(row.blendshapes, dtype=np.float64))[_ORDER]
                angles = np.radians(np.concatenate([row.head, np.asarray(row.eyes, float)]))
                writer.writerow([timecode(row.time, base), 61,
                                 *(f"{v:.6f}" for v in shapes),
                                 *(f"{v:.6f}" for v in angles)])  # fmt: skip
                count += 1
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)
    return count
