"""Synchrony of the participant's and the robot's face (issue 32): windowed lagged
cross-correlation as rMEA's MEAccf, surrogate baselines, the copy check. Pure: no I/O."""

from chameleons.experiment.stats.synchrony.measure import (
    METHOD_VERSION,
    SynchronyResult,
    SyncParams,
    mask_speech,
    measure_synchrony,
)
from chameleons.experiment.stats.synchrony.streams import FaceStream

__all__ = [
    "METHOD_VERSION",
    "FaceStream",
    "SyncParams",
    "SynchronyResult",
    "mask_speech",
    "measure_synchrony",
]
