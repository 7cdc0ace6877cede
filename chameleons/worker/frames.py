"""The one face-frame type every stage speaks, and the canonical ARKit blendshape names.

Canonical names are ARKit camelCase (``eyeBlinkLeft``) in the de-facto index order used by
Live Link Face (protocols.md section 1). "Left" is the subject's own left.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from chameleons.arkit.blendshapes import BLENDSHAPE_INDEX as BLENDSHAPE_INDEX
from chameleons.arkit.blendshapes import BLENDSHAPE_NAMES as BLENDSHAPE_NAMES
from chameleons.arkit.blendshapes import EYE_NAMES as EYE_NAMES
from chameleons.arkit.blendshapes import HEAD_NAMES as HEAD_NAMES
from chameleons.arkit.blendshapes import N_BLENDSHAPES as N_BLENDSHAPES

F32Array = npt.NDArray[np.float32]

# Mouth and jaw channels: lip-sync owns these while the robot speaks.
MOUTH_JAW_INDICES: tuple[int, ...] = tuple(
    i for i, n in enumerate(BLENDSHAPE_NAMES) if n.startswith(("mouth", "jaw"))
)
# Names that end in Left/Right but keep them in Swift raw values (jaw/mouth sideways moves).
_SIDEWAYS = {"jawLeft", "jawRight", "mouthLeft", "mouthRight"}


def _mirror_permutation() -> npt.NDArray[np.intp]:
    perm = np.arange(N_BLENDSHAPES)
    for i, name in enumerate(BLENDSHAPE_NAMES):
        for a, b in (("Left", "Right"), ("Right", "Left")):
            if name.endswith(a):
                perm[i] = BLENDSHAPE_INDEX[name[: -len(a)] + b]
    return perm


MIRROR_PERMUTATION = _mirror_permutation()


def _lookup_key(name: str) -> str:
    return name.replace("_", "").lower()


_LOOKUP: dict[str, str] = {_lookup_key(n): n for n in BLENDSHAPE_NAMES}
# Categories that are not blendshapes and are dropped by name, not counted as unknown:
# MediaPipe Face Landmarker's category 0 is "_neutral" (protocols.md section 5).
IGNORED_NAMES = frozenset({"_neutral"})


def ignored_name(raw: str) -> bool:
    return raw.strip() in IGNORED_NAMES


def canonical_name(raw: str) -> str | None:
    """Map any spelling in the wild (camelCase, PascalCase, Swift ``_L``/``_R``, UPPER_SNAKE)
    to the canonical camelCase name, or None when it is not an ARKit blendshape."""
    name = raw.strip()
    if name.endswith(("_L", "_R")):
        name = name[:-2] + ("Left" if name.endswith("_L") else "Right")
    return _LOOKUP.get(_lookup_key(name))


def upper_snake(name: str) -> str:
    """``eyeBlinkLeft`` -> ``EYE_BLINK_LEFT`` (Furhat's ARKit parameter names)."""
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).upper()


def swift_raw_name(name: str) -> str:
    """``eyeBlinkLeft`` -> ``eyeBlink_L`` (what FaceCaptureX sends)."""
    if name in _SIDEWAYS:
        return name
    for side, suffix in (("Left", "_L"), ("Right", "_R")):
        if name.endswith(side):
            return name[: -len(side)] + suffix
    return name


def zeros(n: int) -> F32Array:
    return np.zeros(n, dtype=np.float32)


@dataclass(slots=True)
class FaceFrame:
    """One face sample.

    ``capture_time`` is the sender's clock where it gives one, else the receive time;
    ``receive_time`` is this host's ``time.monotonic()``. The ingest receivers map the
    sender's clock onto this host's monotonic clock (``ingest.stats.ClockAligner``), so a
    published frame has ``capture_time <= receive_time`` on one clock. Blendshapes are
    clamped to 0..1; head (yaw, pitch, roll) and eyes (left yaw/pitch/roll, right
    yaw/pitch/roll) in degrees.

    ``missing``: blendshape indices the source cannot measure (a webcam's cheekPuff,
    jawForward, tongueOut...): 0 (at rest) in ``blendshapes``, so the robot gets a finite
    face, and NaN in recordings. ``calibration``: how a webcam source was calibrated
    (``geometric``, ``neutral``, ``iphone:<hash>``...; empty for an iPhone).
    """

    capture_time: float
    receive_time: float
    blendshapes: F32Array = field(default_factory=lambda: zeros(N_BLENDSHAPES))
    head: F32Array = field(default_factory=lambda: zeros(3))
    eyes: F32Array = field(default_factory=lambda: zeros(6))
    source: str = ""
    missing: tuple[int, ...] = ()
    calibration: str = ""

    VECTOR_SIZE = N_BLENDSHAPES + 3 + 6

    def to_vector(self) -> F32Array:
        return np.concatenate([self.blendshapes, self.head, self.eyes]).astype(np.float32)

    @classmethod
    def from_vector(
        cls, vector: F32Array, capture_time: float, receive_time: float, source: str = ""
    ) -> FaceFrame:
        if vector.shape != (cls.VECTOR_SIZE,):
            raise ValueError(f"face vector must have {cls.VECTOR_SIZE} values, got {vector.shape}")
        v = vector.astype(np.float32, copy=True)
        return cls(
            capture_time, receive_time, v[:N_BLENDSHAPES], v[N_BLENDSHAPES : N_BLENDSHAPES + 3],
            v[N_BLENDSHAPES + 3 :], source,
        )  # fmt: skip

    def mirrored(self) -> FaceFrame:
        """The mirror image: Left/Right channels swapped, yaw and roll negated."""
        head = self.head * np.array([-1, 1, -1], dtype=np.float32)
        eyes = self.eyes[[3, 4, 5, 0, 1, 2]] * np.array([-1, 1, -1, -1, 1, -1], dtype=np.float32)
        missing = tuple(sorted(int(MIRROR_PERMUTATION[i]) for i in self.missing))
        return FaceFrame(
            self.capture_time, self.receive_time, self.blendshapes[MIRROR_PERMUTATION], head,
            eyes, self.source, missing, self.calibration,
        )  # fmt: skip

    def recorded_vector(self) -> F32Array:
        """:meth:`to_vector` with the missing channels NaN: what recordings keep."""
        vector = self.to_vector()
        if self.missing:
            vector[list(self.missing)] = np.nan
        return vector


def neutral_frame(now: float = 0.0, source: str = "neutral") -> FaceFrame:
    return FaceFrame(capture_time=now, receive_time=now, source=source)
