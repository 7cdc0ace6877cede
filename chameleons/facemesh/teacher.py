"""The iPhone as the webcam's teacher: per ARKit channel, a ridge regression from the
webcam's expression features to the iPhone's values, recorded at the same time.

Fit (:func:`fit_map`): the paired frames are the webcam's feature rows (relative to the
participant's neutral face, :mod:`chameleons.facemesh.features`) and the iPhone's 52 values
at the same capture times. The last ``holdout`` share of the frames (in time: a later
stretch, not a random sample, so neighbouring frames do not leak) is held out; each channel
gets the closed-form ridge solution on standardised features (``(X'X + lambda I)^-1 X'y``,
intercept unpenalised), lambda chosen from :data:`LAMBDAS` by the held-out error of a
split inside the training part. The two capture paths differ in delay, so the pairs are
first shifted by the lag (within +-0.5 s) whose fits predict the held-out frames best over
all channels; each channel reports its own such lag (seconds, positive: the webcam behind
the iPhone) and, on the held-out frames of the aligned fit, R² and Pearson's correlation.
Channels the webcam cannot measure (cheekPuff, jawForward, tongueOut) are not fitted.

The map is a :class:`~chameleons.facemesh.arkit.LinearMap` named ``iphone:<hash>`` (the
SHA-256 of its weights), stored as JSON (:func:`map_to_json`); a booth's webcam uses it in
place of the geometric defaults. Pure numpy, no I/O.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from chameleons.arkit.blendshapes import BLENDSHAPE_INDEX, BLENDSHAPE_NAMES, N_BLENDSHAPES
from chameleons.facemesh.arkit import NEVER_DERIVED, LinearMap, geometric_map
from chameleons.facemesh.features import FEATURE_NAMES, N_FEATURES

F64Array = npt.NDArray[np.float64]
LAMBDAS: Final = (0.01, 0.1, 1.0, 10.0, 100.0)
MAX_LAG_S: Final = 0.5


@dataclass(frozen=True)
class ChannelReport:
    channel: str
    r2: float
    correlation: float
    lag_s: float
    ridge_lambda: float


@dataclass(frozen=True)
class Teaching:
    mapping: LinearMap
    channels: tuple[ChannelReport, ...]
    train_frames: int
    test_frames: int
    aligned_s: float = 0.0  # the webcam's delay behind the iPhone the pairs were shifted by


def _ridge(x: F64Array, y: F64Array, lam: float) -> tuple[F64Array, float]:
    """Weights on the raw features and intercept, fitted on standardised features."""
    mean, scale = x.mean(axis=0), x.std(axis=0)
    scale = np.where(scale > 1e-12, scale, 1.0)
    z = (x - mean) / scale
    gram = z.T @ z + lam * len(z) * np.eye(z.shape[1])
    beta = np.linalg.solve(gram, z.T @ (y - y.mean()))
    weights = beta / scale
    return weights, float(y.mean() - mean @ weights)


def _r2(truth: F64Array, predicted: F64Array) -> float:
    total = float(((truth - truth.mean()) ** 2).sum())
    return float("nan") if total <= 0 else 1.0 - float(((truth - predicted) ** 2).sum()) / total


def _correlation(a: F64Array, b: F64Array) -> float:
    if a.std() <= 0 or b.std() <= 0:
        return float("nan")
    return float(np.corrcoef(a, b)[0, 1])


def fit_map(features: npt.ArrayLike, targets: npt.ArrayLike, neutral: npt.ArrayLike,
            *, rate: float, holdout: float = 0.25) -> Teaching:  # fmt: skip
    """Teach the map from paired frames: ``features`` (n x F, the webcam's), ``targets``
    (n x 52, the iPhone's), equally spaced at ``rate`` frames a second."""
    x = np.nan_to_num(np.asarray(features, np.float64) - np.asarray(neutral, np.float64))
    y = np.asarray(targets, dtype=np.float64)
    if x.shape[0] != y.shape[0] or x.shape[1] != N_FEATURES or y.shape[1] != N_BLENDSHAPES:
        raise ValueError(f"features {x.shape} and targets {y.shape} do not pair up")
    n = len(x)
    cut = int(n * (1 - holdout))
    if cut < 20 or n - cut < 10:
        raise ValueError(f"{n} paired frames are too few to teach and test a map")
    channel_lags = {c: best_shift(x, y[:, BLENDSHAPE_INDEX[c]], cut, rate) / rate
                    for c in BLENDSHAPE_NAMES if c not in NEVER_DERIVED
                    and y[:cut, BLENDSHAPE_INDEX[c]].std() > 1e-9}  # fmt: skip
    shift = _pairing_shift(x, y, cut, rate)
    if shift:  # the two capture paths differ in delay: pair each webcam frame with its own
        x, y = _shifted(x, y, shift)
        cut = int(len(x) * (1 - holdout))
    weights, bias, reports, learned = _fit(x, y, cut, rate, channel_lags)
    unnamed = LinearMap(weights, bias, "iphone", frozenset(learned))
    mapping = LinearMap(weights, bias, f"iphone:{unnamed.digest()}", frozenset(learned))
    return Teaching(mapping, tuple(reports), cut, len(x) - cut, shift / rate)


def _shifted(x: F64Array, y: F64Array, shift: int) -> tuple[F64Array, F64Array]:
    """Pairs with the webcam ``shift`` frames behind: its frame t + shift shows the
    iPhone's frame t (negative: ahead)."""
    if shift > 0:
        return x[shift:], y[:-shift]
    if shift < 0:
        return x[:shift], y[-shift:]
    return x, y


def _held_out_r2(x: F64Array, target: F64Array, cut: int) -> float:
    w, b = _ridge(x[:cut], target[:cut], 1.0)
    return _r2(target[cut:], np.clip(x[cut:] @ w + b, 0, 1))


def best_shift(x: F64Array, target: F64Array, cut: int, rate: float = 30.0) -> int:
    """Frames by which the webcam trails the iPhone for one channel: the shift whose fit
    predicts the held-out frames best (within +-``MAX_LAG_S``)."""
    limit = max(1, round(MAX_LAG_S * rate))
    scores = []
    for shift in range(-limit, limit + 1):
        xs, ys = _shifted(x, target[:, None], shift)
        scores.append(_held_out_r2(xs, ys[:, 0], cut - abs(shift)))
    values = np.nan_to_num(np.array(scores), nan=-np.inf)
    return int(np.argmax(values)) - limit


def _pairing_shift(x: F64Array, y: F64Array, cut: int, rate: float = 30.0) -> int:
    """The shift that pairs the two streams best over every channel that moves."""
    moving = [k for k in range(N_BLENDSHAPES) if y[:cut, k].std() > 1e-9
              and BLENDSHAPE_NAMES[k] not in NEVER_DERIVED]  # fmt: skip
    if not moving:
        return 0
    limit = max(1, round(MAX_LAG_S * rate))
    totals = []
    for shift in range(-limit, limit + 1):
        xs, ys = _shifted(x, y, shift)
        r2 = [_held_out_r2(xs, ys[:, k], cut - abs(shift)) for k in moving]
        totals.append(float(np.nansum(np.maximum(r2, 0.0))))
    return int(np.argmax(totals)) - limit


def _fit(x: F64Array, y: F64Array, cut: int, rate: float, lags: dict[str, float]) -> tuple[
        F64Array, F64Array, list[ChannelReport], set[str]]:  # fmt: skip
    """Every channel's ridge fit on frames before ``cut``, judged on the rest; a channel's
    lag is the one measured before alignment when given."""
    inner = int(cut * 0.8)
    base = geometric_map()
    weights, bias = base.weights.copy(), base.bias.copy()
    reports, learned = [], set()
    for channel in BLENDSHAPE_NAMES:
        if channel in NEVER_DERIVED:
            continue
        k = BLENDSHAPE_INDEX[channel]
        target = y[:, k]
        if target[:cut].std() <= 1e-9:
            continue  # the iPhone never moved it: nothing to learn
        errors = []
        for lam in LAMBDAS:
            w, b = _ridge(x[:inner], target[:inner], lam)
            errors.append(float(((x[inner:cut] @ w + b - target[inner:cut]) ** 2).mean()))
        lam = LAMBDAS[int(np.argmin(errors))]
        w, b = _ridge(x[:cut], target[:cut], lam)
        predicted = np.clip(x[cut:] @ w + b, 0, 1)
        truth = target[cut:]
        lag = lags.get(channel, 0.0)
        reports.append(ChannelReport(channel, _r2(truth, predicted),
                                     _correlation(truth, predicted), lag, lam))  # fmt: skip
        weights[k], bias[k] = w, b
        learned.add(channel)
    return weights, bias, reports, learned


def map_to_json(mapping: LinearMap, teaching: Teaching | None = None) -> str:
    """The map as JSON, with its hash and (when given) the agreement it was taught with."""
    body: dict[str, Any] = {
        "name": mapping.name, "sha256_16": mapping.digest(), "features": list(FEATURE_NAMES),
        "channels": list(BLENDSHAPE_NAMES), "learned": sorted(mapping.learned),
        "weights": mapping.weights.tolist(), "bias": mapping.bias.tolist(),
    }  # fmt: skip
    if teaching is not None:
        body["agreement"] = [vars(r) for r in teaching.channels]
        body["frames"] = {"train": teaching.train_frames, "test": teaching.test_frames}
        body["aligned_s"] = teaching.aligned_s
    return json.dumps(body, allow_nan=True)


def map_from_json(text: str) -> LinearMap:
    """Read a stored map; refuses one whose weights do not match its hash."""
    body = json.loads(text)
    if body.get("features") != list(FEATURE_NAMES):
        raise ValueError("the map was taught on other features than this version measures")
    mapping = LinearMap(np.array(body["weights"], dtype=np.float64),
                        np.array(body["bias"], dtype=np.float64), str(body["name"]),
                        frozenset(body.get("learned", ())))  # fmt: skip
    if mapping.digest() != body.get("sha256_16"):
        raise ValueError("the map's weights do not match its hash: the file was changed")
    return mapping
