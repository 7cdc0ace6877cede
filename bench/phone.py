"""A simulated phone process for benchmarks: the synthetic face as Live Link UDP at 60 fps.

``python -m bench.phone --port P --duration S [--seed N]``
"""

from __future__ import annotations

import argparse

from chameleons.worker.simulate import LiveLinkSender, SyntheticFace, run_simulation


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--duration", type=float, required=True)
    parser.add_argument("--fps", type=float, default=60.0)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    sender = LiveLinkSender("127.0.0.1", args.port, fps=args.fps)
    run_simulation(sender, SyntheticFace(args.seed).samples(args.fps, args.duration))


if __name__ == "__main__":
    main()
