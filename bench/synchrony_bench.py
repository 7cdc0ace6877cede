"""Synchrony benchmark (issue 32): the time one interaction's synchrony takes, beside a
bare NumPy correlation of the same arrays, all in the same run.

``python -m bench.synchrony_bench [--quick] [--seconds S] [--surrogates N] [--repeat R]
[--json FILE]``

The interaction is synthetic and sized like a real one: a participant's face at 60 Hz for
S seconds (default 300) with all 55 channels the measure uses (head yaw, pitch, roll and
the 52 blendshapes), a robot copying it at 4 s at 125 Hz, and N pseudo-pairs (default 40,
other participants' faces) for the baseline, at the default parameters (25 Hz, 30 s
windows every 15 s, lags +-6 s). Timed, as medians over R runs:

- **per interaction**: :func:`measure_synchrony` with its N pseudo-pairs (resampling, the
  windowed lagged cross-correlation of every pair, peaks, band): what the background thread
  spends on one interaction once its recordings are read;
- **the real pair only**: the same without pseudo-pairs' curves (one windowed lagged
  cross-correlation of 55 channels);
- **baseline**: ``numpy.correlate(x, y, "full")`` of the same resampled arrays, channel by
  channel: one plain cross-correlation at every lag, no windows, no missing data.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from chameleons.experiment.stats.synchrony import SyncParams, measure_synchrony
from chameleons.experiment.stats.synchrony.measure import lag_curves
from chameleons.experiment.stats.synchrony.streams import grid, resample
from chameleons.worker.frames import BLENDSHAPE_NAMES
from tests.experiment.synchrony_data import delayed, smooth_face

CHANNELS = ("head_yaw", "head_pitch", "head_roll", *BLENDSHAPE_NAMES)


def _median(action: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def run(seconds: float, surrogates: int, repeat: int) -> dict[str, Any]:
    params = SyncParams(surrogates=surrogates, min_between=min(10, surrogates))
    participant = smooth_face(1, seconds, channels=CHANNELS)
    robot = delayed(participant, 4.0, noise=0.01)
    pairs = []
    for seed in range(surrogates // 2 + 1):
        other = smooth_face(100 + seed, seconds, channels=CHANNELS)
        pairs += [(participant, delayed(other, 4.0)), (other, robot)]
    pairs = pairs[:surrogates]
    times = grid(max(participant.start, robot.start), min(participant.end, robot.end), 25)
    p, r = resample(participant, times, 0.25), resample(robot, times, 0.25)
    found = measure_synchrony(participant, robot, pairs, params, 4.0)
    whole = _median(lambda: measure_synchrony(participant, robot, pairs, params, 4.0), repeat)
    real = _median(lambda: lag_curves(p, r, list(CHANNELS), params), repeat)
    bare = _median(lambda: [np.correlate(p[:, k], r[:, k], "full") for k in range(p.shape[1])],
                   repeat)  # fmt: skip
    return {
        "seconds": seconds, "channels": len(CHANNELS), "surrogates": found.surrogate_count,
        "surrogate_kind": found.surrogate_kind, "windows": found.windows,
        "measured_lag_s": found.sync_lag_s, "repeat": repeat,
        "per_interaction_s": whole, "real_pair_s": real, "bare_numpy_s": bare,
        "per_interaction_ratio": whole / bare, "real_pair_ratio": real / bare,
    }  # fmt: skip


def parser() -> argparse.ArgumentParser:
    found = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    found.add_argument("--quick", action="store_true", help="60 s, 6 pseudo-pairs, 1 run.")
    found.add_argument("--seconds", type=float, default=300.0)
    found.add_argument("--surrogates", type=int, default=40)
    found.add_argument("--repeat", type=int, default=5)
    found.add_argument("--json", type=Path, help="Write the figures here.")
    return found


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if args.quick:
        args.seconds, args.surrogates, args.repeat = 60.0, 6, 1
    figures = run(args.seconds, args.surrogates, args.repeat)
    print(f"synchrony of one {figures['seconds']:.0f} s interaction, {figures['channels']} "
          f"channels, {figures['windows']} windows, {figures['surrogates']} "
          f"{figures['surrogate_kind']} pseudo-pairs (copy measured at "
          f"{figures['measured_lag_s']} s), median of {figures['repeat']}:")  # fmt: skip
    print(f"  per interaction      {figures['per_interaction_s'] * 1000:9.1f} ms "
          f"({figures['per_interaction_ratio']:.0f}x the baseline)")  # fmt: skip
    print(f"  the real pair only   {figures['real_pair_s'] * 1000:9.1f} ms "
          f"({figures['real_pair_ratio']:.1f}x)")  # fmt: skip
    print(f"  baseline: numpy.correlate of the same arrays, channel by channel "
          f"{figures['bare_numpy_s'] * 1000:.1f} ms")  # fmt: skip
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(figures, indent=2), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
