"""The Python face tracker's cost per 640x480 frame, beside the bare model invokes of the
same run: ``python -m bench.facemesh_bench [--quick] [--json FILE]``.

Per frame (the median over the run): detection (letterbox + invoke + decode) as run when a
face is lost, landmarks while tracking (crop + invoke + projection), the mapping (pose fit,
features, ARKit values), and the bare ``invoke()`` of each model; the ratio of the tracked
frame's total to its bare landmark invoke is the price of the numpy pre- and
post-processing. Frames: a real face photo (tests/support/faces.py) rolling in the image.
``fps`` is frames per second of the tracked path on one thread of this machine with the
models' 2 threads.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np

from chameleons.facemesh.mapping import read_face
from chameleons.facemesh.tracker import FaceTracker
from tests.support.faces import Motion, scene


def parser() -> argparse.ArgumentParser:
    found = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    found.add_argument("--quick", action="store_true", help="60 frames instead of 300.")
    found.add_argument("--json", type=Path, help="Write the figures here.")
    return found


def run(frames: int) -> dict[str, float]:
    tracker = FaceTracker()
    images = [scene("astronaut", Motion(angle=15 * np.sin(k / 10))) for k in range(frames)]
    detect, detect_invoke, track, track_invoke, mapping, total = [], [], [], [], [], []
    for image in images[:10]:  # warm-up
        tracker.process(image)
    for image in images:
        tracker.reset()  # a detection frame
        tracker.process(image)
        detect.append(tracker.timings.detect)
        detect_invoke.append(tracker.timings.detect_invoke)
        started = time.perf_counter()  # a tracked frame (ROI from the previous landmarks)
        face = tracker.process(image)
        assert face is not None
        landmarks_done = time.perf_counter()
        read_face(face.landmarks, face.width, face.height)
        done = time.perf_counter()
        track.append(tracker.timings.landmarks)
        track_invoke.append(tracker.timings.landmarks_invoke)
        mapping.append(done - landmarks_done)
        total.append(done - started)
    ms = {name: 1000 * statistics.median(values) for name, values in (
        ("detect_ms", detect), ("detect_invoke_ms", detect_invoke), ("landmarks_ms", track),
        ("landmarks_invoke_ms", track_invoke), ("mapping_ms", mapping),
        ("tracked_frame_ms", total))}  # fmt: skip
    ms["tracked_over_bare_invoke"] = ms["tracked_frame_ms"] / ms["landmarks_invoke_ms"]
    ms["fps_640x480"] = 1000 / ms["tracked_frame_ms"]
    ms["frames"] = frames
    return ms


def main() -> None:
    args = parser().parse_args()
    figures = run(60 if args.quick else 300)
    for name, value in figures.items():
        print(f"{name:28s} {value:8.2f}")
    if args.json is not None:
        args.json.write_text(json.dumps(figures, indent=2), encoding="utf-8")


if __name__ == "__main__":
    main()
