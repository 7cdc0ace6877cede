"""The server bench's HTTP timing against an independent load generator: ``wrk`` (Will
Glozer's C load generator, Debian's ``wrk`` package) and the bench's own client (httpx in
one thread per connection, as ``bench.server_bench``'s phones) read the same phone's view,
``GET /api/phone/{token}/state``, from the same ``chameleons serve`` at the same number of
connections, one after the other and then again (A B A B). If the bench's percentiles
match wrk's within the noise between the two A runs, its HTTP figures measure the server
and not the bench's client. (The console state the wizard sees has its own independent
check: ``bench.console_dom_bench``, in Chromium.)

    python -m bench.independent_check [--connections 1 8] [--seconds 10] [--quick] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from bench.server_load import Figures, Server, percentile, run_threads
from bench.server_walk import RealServer

# wrk --latency prints "Latency Distribution" then lines such as "     50%    1.23ms".
WRK_PERCENTILE = re.compile(r"^\s*(50|99)%\s+([\d.]+)(us|ms|s)\s*$", re.MULTILINE)
WRK_RATE = re.compile(r"^Requests/sec:\s+([\d.]+)", re.MULTILINE)
TO_MS = {"us": 0.001, "ms": 1.0, "s": 1000.0}


def wrk(url: str, connections: int, seconds: float) -> dict[str, float]:
    """wrk's p50, p99 (ms) and requests a second; one wrk thread per connection (at most
    the machine's two cores' worth: its threads are event loops)."""
    command = ["wrk", f"-t{min(connections, 2)}", f"-c{connections}", f"-d{seconds:g}s",
               "--latency", url]  # fmt: skip
    done = subprocess.run(command, capture_output=True, text=True, timeout=seconds + 60,
                          check=True)  # fmt: skip
    found = {f"p{q}_ms": float(value) * TO_MS[unit]
             for q, value, unit in WRK_PERCENTILE.findall(done.stdout)}  # fmt: skip
    rate = WRK_RATE.search(done.stdout)
    if len(found) != 2 or rate is None:
        raise RuntimeError(f"wrk's output was not understood:\n{done.stdout}{done.stderr}")
    return {**found, "per_second": float(rate.group(1))}


def own_client(server: Server, path: str, connections: int, seconds: float) -> dict[str, float]:
    """The bench's client: ``connections`` threads, each its own httpx client (kept-alive
    connection), requesting back to back for ``seconds``."""
    times: list[float] = []
    lock = threading.Lock()
    deadline = time.monotonic() + seconds

    def loop() -> None:
        with server.client() as http:
            while time.monotonic() < deadline:
                started = time.perf_counter()
                http.get(path).raise_for_status()
                took = time.perf_counter() - started
                with lock:
                    times.append(took)

    run_threads([loop] * connections, together=True)
    return {"p50_ms": percentile(times, 0.5) * 1000, "p99_ms": percentile(times, 0.99) * 1000,
            "per_second": len(times) / seconds}  # fmt: skip


def compare(connections: list[int], seconds: float) -> dict[str, Any]:
    if shutil.which("wrk") is None:
        raise RuntimeError("wrk is not installed (Debian: apt-get install wrk)")
    runs: dict[str, Any] = {}
    with (tempfile.TemporaryDirectory(prefix="chameleons-check-") as tmp,
          Server.chameleons(f"sqlite:///{Path(tmp) / 'check.sqlite3'}", sessions=1)
          as (server, setup)):  # fmt: skip
        real = RealServer.of(server, setup)
        phone = real.new_phone()
        path = f"/api/phone/{phone.wizard.token}/state"
        phone.participant.state()  # the first read warms the server's caches
        for count in connections:
            order = [("wrk", 1), ("bench", 1), ("wrk", 2), ("bench", 2)]
            runs[str(count)] = {
                f"{who} {n}": (wrk(server.base + path, count, seconds) if who == "wrk"
                               else own_client(server, path, count, seconds))
                for who, n in order
            }  # fmt: skip
        real.release(phone, Figures())
    return runs


def report(runs: dict[str, Any]) -> None:
    print("GET /api/phone/{token}/state, chameleons serve on SQLite, A B A B:")
    print(f"{'connections':<12}{'generator':<10}{'p50 ms':>9}{'p99 ms':>9}{'per s':>9}")
    for count, found in runs.items():
        for name, figures in found.items():
            print(f"{count:<12}{name:<10}{figures['p50_ms']:>9.2f}{figures['p99_ms']:>9.2f}"
                  f"{figures['per_second']:>9.0f}")  # fmt: skip


def parser() -> argparse.ArgumentParser:
    found = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    found.add_argument("--connections", type=int, nargs="+", default=[1, 8])
    found.add_argument("--seconds", type=float, default=10.0)
    found.add_argument("--quick", action="store_true", help="2 s a run")
    found.add_argument("--json", type=Path, help="write the figures to this file")
    return found


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    runs = compare(args.connections, 2.0 if args.quick else args.seconds)
    report(runs)
    if args.json:
        args.json.write_text(json.dumps(runs, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
