"""Expression features -> ARKit's 52 blendshape values, against the face at rest.

Every channel is a clipped linear function of how far the features moved from the
neutral face: ``value = clip(sum_k w_k (f_k - neutral_k) + b, 0, 1)``. The geometric
defaults (:data:`GEOMETRIC_WEIGHTS`) name, per channel, the features that move with it and
how far a full movement goes (a coefficient of 1 / that distance, in inter-ocular
distances); an iPhone-taught map (:mod:`chameleons.facemesh.teacher`) replaces the
weights and bias of the channels it learned with a ridge regression on the same features.

Missing, not zero: ``cheekPuff`` (the cheek's bulge is not in the landmarks' shape),
``jawForward`` (depth of the jaw from one camera) and ``tongueOut`` (no tongue landmarks)
cannot be derived, and without irises (the 468-point mesh) neither can the eight
``eyeLook*`` channels. They are NaN in :attr:`Expression.blendshapes` and listed in
:attr:`Expression.missing`; recordings keep them NaN, the robot gets 0.

Eye rotation (degrees, the ARKit convention of :mod:`chameleons.arkit.rotation`) is
the iris's offset from the eye's centre in eye widths times :data:`GAZE_DEGREES_PER_WIDTH`
(an iris a quarter of the eye's width off centre is a 30 degree turn, roughly the eyeball's
geometry: radius ~12 mm, eye width ~30 mm).

The neutral face: by default :data:`DEFAULT_NEUTRAL`, the features this tracker measures on
a public-domain portrait at rest at webcam scale (Grace Hopper, US Navy photograph, shipped as
matplotlib's sample ``grace_hopper.jpg``; tests/data/faces). The canonical mesh is no
neutral face: its mouth stands open and its brows high. :func:`neutral_from` makes the
participant's own from a few seconds of frames at rest (the capture page's calibration
step), the median of each feature.

Pure functions: no I/O.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from typing import Final

import numpy as np
import numpy.typing as npt

from chameleons.arkit.blendshapes import BLENDSHAPE_INDEX, BLENDSHAPE_NAMES, N_BLENDSHAPES
from chameleons.facemesh.features import FEATURE_INDEX, FEATURE_NAMES, GAZE, N_FEATURES

F64Array = npt.NDArray[np.float64]
NEVER_DERIVED: Final = ("cheekPuff", "jawForward", "tongueOut")
GAZE_CHANNELS: Final = tuple(n for n in BLENDSHAPE_NAMES if n.startswith("eyeLook"))
GAZE_DEGREES_PER_WIDTH: Final = 120.0

# Measured with chameleons.facemesh (the Python tracker, tracking, pose fit and features) on
# tests/data/faces/grace_hopper.jpg as a webcam sees a face at arm's length (640x480, the
# face about 130 px wide: tests/support/faces.py's scene), mean of 5 frames, both sides
# averaged, jaw and mouth centred by symmetry.
DEFAULT_NEUTRAL: Final[dict[str, float]] = {
    "eye_open": 0.107, "lower_lid": -0.033, "brow_inner": 0.308, "brow_mid": 0.325,
    "brow_outer": 0.201, "corner_y": -0.326, "corner_out": 0.400, "upper_side_y": -0.173,
    "lower_side_y": -0.431, "cheek_y": -0.266, "nose_wing_y": -0.510, "lip_gap": 0.021,
    "jaw_drop": 1.013, "jaw_x": 0.0, "mouth_width": 0.799, "mouth_x": 0.0,
    "upper_lip_y": -0.189, "lower_lip_y": -0.439, "upper_lip_thickness": 0.097,
    "lower_lip_thickness": 0.133, "lip_forward": -0.020,
    "gaze_x": 0.0, "gaze_y": 0.0,
}  # fmt: skip

Terms = dict[str, float]


def _sided(left: Terms, side: str) -> Terms:
    return {f"{k}_{side}" if k in _SIDED_BASES else k: v for k, v in left.items()}


_SIDED_BASES = frozenset({
    "eye_open", "lower_lid", "brow_inner", "brow_mid", "brow_outer", "corner_y", "corner_out",
    "upper_side_y", "lower_side_y", "cheek_y", "nose_wing_y", "gaze_x", "gaze_y",
})  # fmt: skip


def _both(name: str, terms: Terms, out: dict[str, Terms], *, outward_x: bool = False) -> None:
    """``name`` + Left/Right from one side's terms (``gaze_x`` flips sign on the right
    when ``outward_x``: the right eye's outward is -x)."""
    for side, suffix in (("L", "Left"), ("R", "Right")):
        sided = _sided(terms, side)
        if outward_x and side == "R":
            sided = {k: (-v if k.startswith("gaze_x") else v) for k, v in sided.items()}
        out[f"{name}{suffix}"] = sided


def _geometric() -> dict[str, Terms]:
    """Per channel, feature -> coefficient (1 / the feature's travel for a full value)."""
    w: dict[str, Terms] = {}
    _both("eyeBlink", {"eye_open": -1 / 0.08}, w)
    _both("eyeWide", {"eye_open": 1 / 0.05}, w)
    _both("eyeSquint", {"lower_lid": 1 / 0.025, "cheek_y": 1 / 0.08}, w)
    _both("eyeLookOut", {"gaze_x": 1 / 0.22}, w, outward_x=True)
    _both("eyeLookIn", {"gaze_x": -1 / 0.22}, w, outward_x=True)
    _both("eyeLookUp", {"gaze_y": 1 / 0.12}, w)
    _both("eyeLookDown", {"gaze_y": -1 / 0.12}, w)
    w["jawOpen"] = {"jaw_drop": 1 / 0.40}
    w["jawLeft"] = {"jaw_x": 1 / 0.12}
    w["jawRight"] = {"jaw_x": -1 / 0.12}
    w["mouthClose"] = {"jaw_drop": 1 / 0.40, "lip_gap": -1 / 0.30}
    w["mouthFunnel"] = {"mouth_width": -1 / 0.35, "lip_gap": 1 / 0.25, "lip_forward": 1 / 0.1}
    w["mouthPucker"] = {"mouth_width": -1 / 0.25, "lip_forward": 1 / 0.1}
    w["mouthLeft"] = {"mouth_x": 1 / 0.12}
    w["mouthRight"] = {"mouth_x": -1 / 0.12}
    _both("mouthSmile", {"corner_y": 1 / 0.25, "corner_out": 1 / 0.35}, w)
    _both("mouthFrown", {"corner_y": -1 / 0.10}, w)
    _both("mouthDimple", {"corner_out": 1 / 0.15, "corner_y": -1 / 0.20}, w)
    _both("mouthStretch", {"corner_out": 1 / 0.20, "corner_y": -1 / 0.15}, w)
    w["mouthRollLower"] = {"lower_lip_thickness": -1 / 0.08}
    w["mouthRollUpper"] = {"upper_lip_thickness": -1 / 0.06}
    w["mouthShrugLower"] = {"lower_lip_y": 1 / 0.10, "jaw_drop": 1 / 0.10}
    w["mouthShrugUpper"] = {"upper_lip_y": 1 / 0.08}
    _both("mouthPress", {"upper_lip_thickness": -1 / 0.10, "lower_lip_thickness": -1 / 0.10,
                         "lip_gap": -1 / 0.05}, w)  # fmt: skip
    _both("mouthLowerDown", {"lower_side_y": -1 / 0.12, "jaw_drop": -1 / 0.12}, w)
    _both("mouthUpperUp", {"upper_side_y": 1 / 0.08}, w)
    _both("browDown", {"brow_inner": -1 / 0.16, "brow_mid": -1 / 0.16}, w)
    w["browInnerUp"] = {"brow_inner_L": 1 / 0.20, "brow_inner_R": 1 / 0.20}
    _both("browOuterUp", {"brow_outer": 1 / 0.10}, w)
    _both("cheekSquint", {"cheek_y": 1 / 0.08}, w)
    _both("noseSneer", {"nose_wing_y": 1 / 0.06}, w)
    unknown = set(w) - set(BLENDSHAPE_INDEX)
    assert not unknown, unknown
    return w


GEOMETRIC_WEIGHTS: Final[dict[str, Terms]] = _geometric()


def default_neutral() -> F64Array:
    """:data:`DEFAULT_NEUTRAL` as a feature vector."""
    out = np.zeros(N_FEATURES)
    for name, index in FEATURE_INDEX.items():
        base = name[:-2] if name.endswith(("_L", "_R")) else name
        out[index] = DEFAULT_NEUTRAL[base]
    return out


def neutral_from(features: npt.ArrayLike) -> F64Array:
    """The neutral face from several frames at rest (rows): each feature's median.
    Gaze stays 0 (looking straight ahead is the rest of the eyes)."""
    rows = np.asarray(features, dtype=np.float64).reshape(-1, N_FEATURES)
    if not len(rows):
        raise ValueError("no frames to calibrate the neutral face from")
    neutral = default_neutral()
    for column in range(N_FEATURES):
        values = rows[:, column][np.isfinite(rows[:, column])]
        if values.size:
            neutral[column] = float(np.median(values))
    for name in GAZE:
        neutral[FEATURE_INDEX[name]] = 0.0
    return neutral


@dataclass(frozen=True)
class LinearMap:
    """``blendshapes = clip(weights @ (features - neutral) + bias, 0, 1)``, 52 x F weights;
    ``name`` says what it is (``geometric`` or ``iphone:<hash>``)."""

    weights: F64Array
    bias: F64Array
    name: str = "geometric"
    learned: frozenset[str] = field(default_factory=frozenset)  # channels a teacher fitted

    def digest(self) -> str:
        payload = json.dumps({"w": np.round(self.weights, 9).tolist(),
                              "b": np.round(self.bias, 9).tolist()}).encode()  # fmt: skip
        return hashlib.sha256(payload).hexdigest()[:16]


def geometric_map() -> LinearMap:
    weights = np.zeros((N_BLENDSHAPES, N_FEATURES))
    for channel, terms in GEOMETRIC_WEIGHTS.items():
        for feature, coefficient in terms.items():
            weights[BLENDSHAPE_INDEX[channel], FEATURE_INDEX[feature]] = coefficient
    return LinearMap(weights, np.zeros(N_BLENDSHAPES))


@dataclass(frozen=True, slots=True)
class Expression:
    """52 blendshapes (canonical order; NaN where missing), eye rotations (left yaw, pitch,
    roll, right yaw, pitch, roll; degrees, 0 where not derivable) and the missing
    channels' indices."""

    blendshapes: F64Array
    eyes: F64Array
    missing: tuple[int, ...]


_NEVER = tuple(BLENDSHAPE_INDEX[n] for n in NEVER_DERIVED)
_GAZE_IDX = tuple(BLENDSHAPE_INDEX[n] for n in GAZE_CHANNELS)


def expression(features: npt.ArrayLike, neutral: npt.ArrayLike | None = None,
               mapping: LinearMap | None = None) -> Expression:  # fmt: skip
    """Blendshapes and eye rotations of one frame's features."""
    f = np.asarray(features, dtype=np.float64)
    base = default_neutral() if neutral is None else np.asarray(neutral, dtype=np.float64)
    mapping = mapping or _GEOMETRIC
    has_gaze = bool(np.all(np.isfinite(f[[FEATURE_INDEX[n] for n in GAZE]])))
    delta = np.nan_to_num(f - base, nan=0.0)
    values = np.clip(mapping.weights @ delta + mapping.bias, 0.0, 1.0)
    missing = _NEVER if has_gaze else tuple(sorted((*_NEVER, *_GAZE_IDX)))
    values[list(missing)] = np.nan
    eyes = np.zeros(6)
    if has_gaze:
        for offset, side in ((0, "L"), (3, "R")):
            eyes[offset] = GAZE_DEGREES_PER_WIDTH * delta[FEATURE_INDEX[f"gaze_x_{side}"]]
            # pitch > 0 is down; gaze_y > 0 is up
            eyes[offset + 1] = -GAZE_DEGREES_PER_WIDTH * delta[FEATURE_INDEX[f"gaze_y_{side}"]]
    return Expression(values, eyes, missing)


_GEOMETRIC = geometric_map()
FEATURES: Final = FEATURE_NAMES
