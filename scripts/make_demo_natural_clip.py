"""Write the demo natural-movement clip ``prompts/_natural/demo-natural.npz``.

``natural`` replays recorded face motion: in a study, another participant's recorded stream
(the yoked control). Before any participant has been recorded, the server falls back to
this clip: a minute of plausible movement (blinks, head sway, smiles, talking) from the face
simulator, in the ``.npz`` layout :func:`chameleons.worker.behaviours.clips.load_clip` reads
(``times`` in seconds, ``blendshapes`` N x 52, ``head`` N x 3 and ``eyes`` N x 6 in degrees).
The output is deterministic (same seed, same bytes); ``--check`` only reports whether the
committed clip is up to date.

Usage: ``.venv/bin/python scripts/make_demo_natural_clip.py [--out PATH] [--check]``
"""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

import numpy as np

from chameleons.worker.behaviours.clips import load_clip
from chameleons.worker.simulate import SyntheticFace

DEFAULT_OUT = Path(__file__).resolve().parents[1] / "prompts" / "_natural" / "demo-natural.npz"
SECONDS = 60.0
FPS = 30.0  # the renderer interpolates between frames; 30 fps keeps the file small
SEED = 2024  # not the worker's own synthetic stand-in (seed 0): a different face


def clip_bytes(seed: int = SEED, seconds: float = SECONDS, fps: float = FPS) -> bytes:
    samples = list(SyntheticFace(seed).samples(fps, seconds))
    buffer = io.BytesIO()
    np.savez_compressed(
        buffer,
        times=np.array([s.time for s in samples], dtype=np.float64),
        blendshapes=np.stack([s.blendshapes for s in samples]).astype(np.float32),
        head=np.stack([s.head for s in samples]).astype(np.float32),
        eyes=np.stack([s.eyes for s in samples]).astype(np.float32),
    )
    return buffer.getvalue()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--check", action="store_true", help="only compare with --out")
    args = parser.parse_args(argv)
    data = clip_bytes(args.seed)
    if args.check:
        current = args.out.read_bytes() if args.out.is_file() else b""
        if current != data:
            print(f"{args.out} is out of date: run {Path(__file__).name}", file=sys.stderr)
            return 1
        print(f"{args.out} is up to date")
        return 0
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_bytes(data)
    clip = load_clip(args.out)  # the worker must be able to read what was written
    print(f"wrote {args.out}: {len(data) / 1024:.0f} KiB, {clip.duration:.1f} s, "
          f"{len(clip.times)} frames")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
