"""Every server-side benchmark of issue 17 in one run, each in a process of its own.

``python -m bench.all [--quick] [--json-dir DIR] [--worker] [--list]``

In order: ``bench.server_bench`` (think with an instant and a human-paced wizard, burst,
hold; SQLite, and PostgreSQL when ``TEST_DATABASE_URL`` is set), ``bench.submission_calls``
(a ranking submission's calls and statements against the bare app's, which the machine's
load does not change), ``bench.console_dom_bench`` (a ranking until the wizard's console
page in Chromium shows it, beside the console's message), ``bench.independent_check``
(the bench's HTTP timing against wrk's), ``bench.speech_bench``
(wizard click -> speech start, virtual robot and Furhat peer), ``bench.data_bench``
(planning, export, analysis page: time and peak memory), ``bench.cli_bench`` (start-up
CPU), ``bench.display_bench`` (the robot display's 3D head against its 2D face in
Chromium) and ``bench.synchrony_bench`` (one interaction's synchrony beside a bare NumPy
correlation); ``--worker`` adds ``bench.worker_bench`` (the realtime worker, the renderer in its
own process included) and ``bench.webcam_bench`` (the worker's webcam source against the
iPhone path, issue 29). Each prints its figures beside a baseline of its own run. With
``--quick`` each runs its smoke size (each well under two minutes on a quiet 2-core
machine). The exit status is 1 when any benchmark failed or missed one of its goals; the
summary at the end says which.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

from bench.server_load import ROOT

# name -> module and its arguments; "--quick" is added in a quick run.
BENCHES: dict[str, list[str]] = {
    "server": ["bench.server_bench"],
    "calls": ["bench.submission_calls"],
    "console": ["bench.console_dom_bench"],
    "check": ["bench.independent_check"],
    "speech": ["bench.speech_bench"],
    "data": ["bench.data_bench"],
    "cli": ["bench.cli_bench"],
    "display": ["bench.display_bench"],
    "synchrony": ["bench.synchrony_bench"],
}
WORKER = {"worker": ["bench.worker_bench"], "webcam": ["bench.webcam_bench"]}


def commands(quick: bool, json_dir: Path | None, worker: bool) -> dict[str, list[str]]:
    found = {}
    for name, (module, *rest) in {**BENCHES, **(WORKER if worker else {})}.items():
        command = [sys.executable, "-m", module, *rest, *(["--quick"] if quick else [])]
        if json_dir is not None:
            command += ["--json", str(json_dir / f"{name}.json")]
        found[name] = command
    return found


def parser() -> argparse.ArgumentParser:
    found = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    found.add_argument("--quick", action="store_true", help="Each benchmark's smoke size.")
    found.add_argument("--json-dir", type=Path, help="Write each benchmark's figures here.")
    found.add_argument("--worker", action="store_true",
                       help="Also run bench.worker_bench and bench.webcam_bench.")  # fmt: skip
    found.add_argument("--list", action="store_true", help="Print the commands and exit.")
    return found


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    planned = commands(args.quick, args.json_dir, args.worker)
    if args.list:
        for command in planned.values():
            print(" ".join(command[1:]))
        return 0
    if args.json_dir is not None:
        args.json_dir.mkdir(parents=True, exist_ok=True)
    outcomes = {}
    for name, command in planned.items():
        print(f"\n=== {name}: {' '.join(command[1:])}", flush=True)
        started = time.monotonic()
        status = subprocess.run(command, cwd=ROOT, check=False).returncode
        outcomes[name] = (status, time.monotonic() - started)
    print("\n=== summary")
    for name, (status, seconds) in outcomes.items():
        verdict = "ok" if status == 0 else f"exit {status}: failed or a goal NOT met"
        print(f"{name:<8} {seconds:>7.1f} s  {verdict}")
    return 0 if all(status == 0 for status, _ in outcomes.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
