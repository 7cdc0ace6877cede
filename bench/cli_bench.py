"""CLI start-up benchmark: the CPU time and memory of ``chameleons --help`` and of each
command's ``--help`` (its start-up: the command's module and what it imports), each
against a bare ``python -c pass`` measured in the same run.

``python -m bench.cli_bench [--repeat R] [--quick] [--json FILE]``

Each figure is the median over R runs of the child process's user+system CPU time
(``resource.getrusage(RUSAGE_CHILDREN)``, so other load on the machine matters less than
for wall time) and its peak resident memory. The goal: ``chameleons --help`` within 12x
the CPU of ``python -c pass``; the exit status is 1 when it is not met.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
from pathlib import Path

from chameleons.cli.main import COMMANDS

GOAL_RATIO = 12.0


def child_cost(argv: list[str]) -> tuple[float, float]:
    """CPU seconds and peak RSS (MiB) of one run of ``argv``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, after.ru_maxrss / 1024  # ru_maxrss: KiB on Linux, the largest child so far


def measure(argv: list[str], repeat: int) -> dict[str, float]:
    runs = [child_cost(argv) for _ in range(repeat)]
    return {"cpu_s": statistics.median(r[0] for r in runs),
            "max_rss_mib": max(r[1] for r in runs)}  # fmt: skip


def parser() -> argparse.ArgumentParser:
    found = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    found.add_argument("--repeat", type=int, default=7)
    found.add_argument("--quick", action="store_true", help="3 runs of each command.")
    found.add_argument("--json", type=Path, help="Also write the figures here.")
    return found


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if args.quick:
        args.repeat = 3
    cli = [sys.executable, "-m", "chameleons"]
    # The bare interpreter first: peak RSS is a running maximum over children.
    baseline = measure([sys.executable, "-c", "pass"], args.repeat)
    figures = {"python -c pass (baseline)": baseline,
               "chameleons --help": measure([*cli, "--help"], args.repeat)}  # fmt: skip
    for name in sorted(COMMANDS):
        figures[f"chameleons {name} --help"] = measure([*cli, name, "--help"], args.repeat)
    print(f"{'command':<36} {'CPU s':>8} {'x baseline':>11}")
    for name, figure in figures.items():
        ratio = figure["cpu_s"] / baseline["cpu_s"] if baseline["cpu_s"] else float("inf")
        figure["cpu_vs_baseline"] = round(ratio, 1)
        print(f"{name:<36} {figure['cpu_s']:>8.3f} {ratio:>10.1f}x")
    top = figures["chameleons --help"]["cpu_vs_baseline"]
    print(f"chameleons --help: {top}x python -c pass (goal <= {GOAL_RATIO:g}x): "
          f"{'met' if top <= GOAL_RATIO else 'NOT met'}")  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps(figures, indent=2))
    return 0 if top <= GOAL_RATIO else 1


if __name__ == "__main__":
    sys.exit(main())
