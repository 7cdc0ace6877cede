"""How synchrony is computed (:class:`SyncParams`, stored with every result) and the
method's version."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

# 2: the first second of each recording is left out (``settle_s``): a still robot's
# recording could hold the last frames of its crossfade from the condition before.
METHOD_VERSION = 2


@dataclass(frozen=True)
class SyncParams:
    """How synchrony is computed (stored with every result: a number traces back here)."""

    rate_hz: int = 25  # grid rate: 0.04 s lag steps (rMEA's 25 fps), refined by a parabola
    window_s: float = 30.0  # rMEA winSec
    increment_s: float = 15.0  # rMEA incSec: half-overlapping windows
    max_lag_s: float = 6.0  # rMEA lagSec: +-6 s covers the copy's 4 s delay with room
    max_gap_s: float = 0.25  # frames further apart than this: a capture gap (missing)
    speech_margin_s: float = 0.5  # mouth/jaw of the robot missing this long around speech
    min_motion: float = 1e-6  # a channel whose SD is below this does not move
    # Left out at the start of each recording: the robot's crossfade from the condition
    # before (0.3 s, worker.behaviours.router) may end after the recording has started (the
    # booth flow sets the robot up and starts the recording in lanes of their own), and a
    # still robot's last crossfade frames made it "move" and gave it a lag curve.
    settle_s: float = 1.0
    surrogates: int = 40  # pseudo-pairs per interaction (between, else segment shuffles)
    min_between: int = 10  # fewer usable between-participant pairs: segment shuffling
    segment_s: float = 30.0  # segment length of the within-interaction fallback
    band: float = 0.95  # the surrogate band: this quantile of the surrogate peaks
    lag_tolerance_s: float = 0.2  # a copy's measured lag this far off its delay: flagged
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("window_s", "increment_s", "max_lag_s", "segment_s", "settle_s"):
            samples = getattr(self, name) * self.rate_hz
            if samples < (0 if name == "settle_s" else 1) or abs(samples - round(samples)) > 1e-9:
                raise ValueError(f"{name} = {getattr(self, name)} s is not a whole number of "
                                 f"samples at {self.rate_hz} Hz")  # fmt: skip

    def samples(self, seconds: float) -> int:
        return round(seconds * self.rate_hz)

    @property
    def minimum_s(self) -> float:
        """The shortest overlap of the two streams that gives one window (after the
        settling time)."""
        return self.settle_s + self.window_s + self.max_lag_s

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "method_version": METHOD_VERSION}
