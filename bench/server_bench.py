"""Server benchmark: participant phones against the real server, each figure beside the
same traffic against a bare FastAPI server (``bench.baseline_app``) measured in the same run.

``python -m bench.server_bench [--quick] [--phones 50] [--think-max 3] [--wizard-think 1]
[--hold-phones 200] [--hold-seconds 120] [--phone-servers 1] [--scaling-phones 20]
[--scaling-seconds 30] [--only sqlite|postgresql] [--report-only]``

The server under test is ``chameleons serve`` in a process of its own (as in a lab), on a
fresh SQLite file, or a fresh PostgreSQL database on ``--database-url``'s server (default:
``TEST_DATABASE_URL`` when set; ``--only sqlite|postgresql`` runs one). The load comes from this
process, one thread per phone; every phone holds its own WebSocket (``/ws/p/{token}``, as
the phone page does) and its session's console socket (``/ws/wizard/sessions/{id}``):

- **think**, twice: every phone walks a whole session while its wizard drives it over the
  staff API; before each submission (rankings and questionnaire pages) the phone thinks a
  uniform 0..T s. First with an *instant* wizard (no pause between its actions: a stress
  run, ~8 actions and console recomputes per ranking within milliseconds), then with a
  *human-paced* wizard who thinks a uniform 0..W s before each action (default 1 s).
- **burst**: N more sessions wait at the ranking; all N phones submit at the same moment.
  Then once more while the standard load runs (``--burst-load``, default N phones walking
  sessions at the human pace with their wizards; ``bench.server_burst``).
- **hold** (``bench.server_hold``): many phones (default 200) walk sessions back to back
  at the human pace for a fixed time, every socket held open.
- **think, paced, phone processes** (PostgreSQL, ``--phone-servers N``, default 1): the
  human-paced run again with the phones' links and sockets on N more server processes on
  the same database, the wizards and consoles on the main one (the deployment of docs/deployment.md,
  "More than one server process"): each answer reaches its console through LISTEN/NOTIFY.
- **scaling** (PostgreSQL, ``bench.server_hold.scaling``): phones walking sessions with no
  pause at all for ``--scaling-seconds``, on one server process and then with the phones on
  a second: the throughput's ratio (goal: >= 1.8x).

Figures per scenario: the phone's HTTP round trip and **submit -> console update** (from
just before the POST until the console's WebSocket delivers the event with the
submission's client id), p50/p99 with the ratio to the baseline's p99, errors (any HTTP
error, a wizard action refused or failed, no console update within 60 s), sockets the
server dropped, and the server's CPU per submission. The baseline gets the same phones,
sockets, submissions and think times, with an endpoint that pushes each submission to the
channel's sockets and does nothing else.

Goals (issue 17), checked at the end: submit -> console p99 <= 50 ms at 50 phones with
0-3 s think time (the human-paced wizard), a burst of 50 with p99 <= 500 ms, 200 phones
held, and no error or dropped socket in any scenario, on SQLite and PostgreSQL. The exit
status is 1 when a goal is not met (``--report-only``: 0 whenever the run completed).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import Any

from bench import server_hold
from bench.server_burst import burst, burst_under_load
from bench.server_load import Figures, Server, run_threads, scratch_postgres, server_cpu
from bench.server_walk import BaselinePhone, Pace, RealServer, walk_session

GOALS = {"think_update_p99_ms": 50.0, "burst_update_p99_ms": 500.0, "cpu_ratio": 1.2,
         "scaling_ratio": 1.8}  # fmt: skip
SCENARIOS = {"think_instant": "think, instant wizard (stress)",
             "think_paced": "think, human-paced wizard", "burst": "burst",
             "burst_loaded": "burst, under the standard load"}  # fmt: skip
# PostgreSQL only: the human-paced run with the phones on more server processes (docs/deployment.md,
# "More than one server process"); its baseline is the human-paced run's.
SPLIT, SPLIT_LABEL = "think_paced_split", "think, paced, phone processes"


def run_real(
    database_url: str, baseline_url: str, phones: int, think_max: float, wizard_think: float,
    seed: int, *, bursts: int = 1, burst_only: bool = False, burst_load: int = 0,
) -> tuple[dict[str, Any], dict[str, Any]]:  # fmt: skip
    """Each scenario against ``chameleons serve`` and, at the same moment, the baseline app
    (on ``baseline_url``): the figures of both. ``burst_only``: the burst alone (the CPU
    per submission's comparison), ``bursts`` times. ``burst_load``: one more burst while
    that many phones walk sessions at the human pace (0: not)."""
    walks = 0 if burst_only else 2
    loaded = 0 if burst_only or not burst_load else phones + 3 * burst_load
    with (Server.chameleons(database_url, sessions=(walks + bursts) * phones + loaded)
          as (server, setup), Server.baseline(baseline_url) as base):  # fmt: skip
        real, ours, theirs = RealServer.of(server, setup), {}, {}
        if not burst_only:
            for name, wizard_max in (("think_instant", 0.0), ("think_paced", wizard_think)):
                ours[name], theirs[name] = walk_phones(real, base, name, phones, think_max,
                                                       wizard_max, seed)  # fmt: skip
        ours["burst"], theirs["burst"] = burst(real, base, phones, bursts)
        if loaded:
            ours["burst_loaded"], theirs["burst_loaded"] = burst_under_load(
                real, base, phones, burst_load, think_max, wizard_think, seed)  # fmt: skip
        return ours, theirs


def run_split(
    database_url: str, baseline_url: str, phones: int, think_max: float, wizard_think: float,
    seed: int, phone_servers: int,
) -> tuple[dict[str, Any], dict[str, Any]]:  # fmt: skip
    """The human-paced run with every phone's link and socket on one of ``phone_servers``
    more ``chameleons serve`` processes on the same database (the wizards and consoles on
    the main one): each phone's answer reaches its console through PostgreSQL's
    LISTEN/NOTIFY, and the servers' CPU is that of all of them. The baseline beside it."""
    with (Server.chameleons(database_url, sessions=phones,
                            phone_servers=phone_servers) as (server, setup),
          Server.baseline(baseline_url) as base):  # fmt: skip
        real = RealServer.of(server, setup)
        walked, baseline = walk_phones(real, base, SPLIT, phones, think_max, wizard_think, seed)
        return {**walked, "phone_servers": phone_servers}, baseline


def walk_phones(
    real: RealServer, base: Server, tag: str, phones: int, think_max: float, wizard_max: float,
    seed: int,
) -> tuple[dict[str, Any], dict[str, Any]]:  # fmt: skip
    """``phones`` new sessions walked at once, each at its own seeded pace, and as many
    baseline phones submitting at the same think times until the last session ends; the
    figures of both, with the CPU of every server process each used over the same window."""
    figures, walkers = Figures(), [real.new_phone() for _ in range(phones)]
    paces = [Pace(random.Random(seed + i), think_max, wizard_max) for i in range(phones)]
    theirs, over = Figures(), threading.Event()
    beside = [BaselinePhone(base, f"{tag}-{i}") for i in range(phones)]

    def sessions() -> None:
        try:
            run_threads([partial(walk_session, phone, figures, pace)
                         for phone, pace in zip(walkers, paces, strict=True)])  # fmt: skip
        finally:
            over.set()

    baseline_jobs = [partial(phone.submit, theirs, math.inf,
                             Pace(random.Random(seed + i), think_max, stop=over))
                     for i, phone in enumerate(beside)]  # fmt: skip
    with server_cpu(real.server, figures, *real.phone_servers), server_cpu(base, theirs):
        run_threads([sessions, partial(run_threads, baseline_jobs)])
    for phone in walkers:
        real.release(phone, figures)
    for other in beside:
        other.close(theirs)
    return figures.summary(), theirs.summary()


@contextmanager
def databases(args: argparse.Namespace) -> Iterator[list[tuple[str, str, str]]]:
    """Each database to run: its name, the real server's URL and the baseline app's (a
    database of its own on the same server, or a SQLite file beside it)."""
    with tempfile.TemporaryDirectory(prefix="chameleons-bench-") as tmp:
        found = ([] if args.only == "postgresql"
                 else [("SQLite", f"sqlite:///{Path(tmp) / 'bench.sqlite3'}",
                        f"sqlite:///{Path(tmp) / 'baseline.sqlite3'}")])  # fmt: skip
        server_url = args.database_url or os.environ.get("TEST_DATABASE_URL")
        if args.only == "sqlite" or not server_url:
            yield found
            return
        with scratch_postgres(server_url) as url, scratch_postgres(server_url) as baseline:
            yield [*found, ("PostgreSQL", url, baseline)]


FIGURES = {"http": "HTTP round trip", "update": "submit -> event message",
           "state": "submit -> console state"}  # fmt: skip


def print_table(name: str, result: dict[str, Any], baseline: dict[str, Any]) -> None:
    print(f"\n{name}")
    print(f"{'scenario':<32} {'figure':<26} {'p50 ms':>8} {'p99 ms':>8} {'x base p99':>11} "
          "errors, dropped sockets")  # fmt: skip
    shown = {**SCENARIOS, **({SPLIT: SPLIT_LABEL} if SPLIT in result else {})}
    for scenario, label in shown.items():
        if scenario not in result:  # --burst-only
            continue
        ours, base = result[scenario], baseline.get(scenario, baseline.get("think_paced"))
        if base is None:  # no baseline scenario of that kind ran
            continue
        for figure, what in FIGURES.items():
            p50, p99 = ours[f"{figure}_p50_ms"], ours[f"{figure}_p99_ms"]
            ratio = p99 / base[f"{figure}_p99_ms"] if base[f"{figure}_p99_ms"] else float("nan")
            faults = f"{ours['errors']} {ours['dropped_sockets']}" if figure == "state" else ""
            print(f"{label:<32} {what:<26} {p50:>8.1f} {p99:>8.1f} {ratio:>10.1f}x {faults}")
        cpu, base_cpu = ours["server_cpu_ms_per_submission"], base["server_cpu_ms_per_submission"]
        ratio = f"{cpu / base_cpu:>10.1f}x" if base_cpu else f"{'n/a':>11}"  # 0: under a tick
        print(
            f"{label:<32} {'server CPU / submission':<26} {cpu:>8.1f} {'':>8} {ratio} "
            f"({ours['submissions']} submissions in {ours['seconds']:g} s)"
        )


def goals(report: dict[str, Any], hold_phones: int) -> dict[str, dict[str, bool]]:
    """Each database's goals, met or not; any error or dropped socket fails them. The
    latencies are those of the console's state (what the wizard sees); the CPU goal is the
    burst's (the same submissions on both servers, no wizard), when the baseline is there."""
    found: dict[str, dict[str, bool]] = {}
    for name in ("SQLite", "PostgreSQL"):
        if name not in report:
            continue
        ours = report[name]
        checks = {
            "burst p99 <= 500 ms": ours["burst"]["state_p99_ms"] <= GOALS["burst_update_p99_ms"],
            **({"burst p99 <= 500 ms under the standard load":
                ours["burst_loaded"]["state_p99_ms"] <= GOALS["burst_update_p99_ms"]}
               if "burst_loaded" in ours else {}),
            "no error or dropped socket in any scenario":
                not any(s["errors"] or s["dropped_sockets"]
                        for s in (ours[k] for k in (*SCENARIOS, SPLIT, "hold") if k in ours)),
        }  # fmt: skip
        if "think_paced" in ours:
            checks["think p99 <= 50 ms (human-paced wizard)"] = (
                ours["think_paced"]["state_p99_ms"] <= GOALS["think_update_p99_ms"]
            )
        base = report.get(f"{name} baseline", {}).get("burst")
        if base and base["server_cpu_ms_per_submission"]:
            ratio = ours["burst"]["server_cpu_ms_per_submission"] / base[
                "server_cpu_ms_per_submission"]  # fmt: skip
            checks["burst CPU / submission <= 1.2x baseline"] = ratio <= GOALS["cpu_ratio"]
        if "hold" in ours:
            checks[f"{hold_phones} phones held"] = ours["hold"]["held"] >= hold_phones
        if "scaling" in ours:
            scaled = ours["scaling"]
            clean = not (scaled["one"]["errors"] or scaled["two"]["errors"])
            scales = scaled["throughput_ratio"] >= GOALS["scaling_ratio"]
            checks["two processes: throughput >= 1.8x one"] = clean and scales
        if SPLIT in ours:
            split = ours[SPLIT]
            checks[f"think p99 <= 50 ms, phones on {split['phone_servers']} more process(es)"] = (
                split["state_p99_ms"] <= GOALS["think_update_p99_ms"]
                and not (split["errors"] or split["dropped_sockets"])
            )
        found[name] = checks
    return found


def parser() -> argparse.ArgumentParser:
    found = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    found.add_argument("--phones", type=int, default=50)
    found.add_argument("--think-max", type=float, default=3.0, help="Seconds (uniform 0..T).")
    found.add_argument("--wizard-think", type=float, default=1.0,
                       help="Seconds (uniform 0..W) before each wizard action of the "
                            "human-paced run; the stress run's wizard is instant.")  # fmt: skip
    found.add_argument("--hold-phones", type=int, default=200, help="0: no hold scenario.")
    found.add_argument("--hold-seconds", type=float, default=120.0)
    found.add_argument(
        "--quick",
        action="store_true",
        help="6 phones, 0.3 s think, 0.3 s wizard, hold 10 phones for 8 s.",
    )
    found.add_argument("--burst-only", action="store_true",
                       help="Only the burst (CPU per submission against the baseline): no "
                            "think runs, no phone processes, no hold.")  # fmt: skip
    found.add_argument("--bursts", type=int, default=1,
                       help="Bursts of --phones submissions, one after the other (their CPU "
                            "added up: more submissions per clock tick).")  # fmt: skip
    found.add_argument("--phone-servers", type=int, default=1,
                       help="PostgreSQL: also run the human-paced scenario with the phones "
                            "on this many more server processes (0: not).")  # fmt: skip
    found.add_argument("--burst-load", type=int, default=None,
                       help="Phones walking sessions at the human pace during one more "
                            "burst (default: --phones; 0: no such burst).")  # fmt: skip
    found.add_argument("--scaling-phones", type=int, default=20)
    found.add_argument("--scaling-seconds", type=float, default=30.0,
                       help="PostgreSQL: each run of the scaling scenario (0: not).")  # fmt: skip
    found.add_argument("--database-url", default=None, help="PostgreSQL server to use.")
    found.add_argument("--only", choices=("sqlite", "postgresql"), default=None,
                       help="Run one database only.")  # fmt: skip
    found.add_argument("--seed", type=int, default=0)
    found.add_argument(
        "--report-only",
        action="store_true",
        help="Exit 0 whenever the run completed, goals met or not.",
    )
    found.add_argument("--json", type=Path, help="Also write the figures here.")
    return found


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if args.quick:
        args.phones, args.think_max, args.wizard_think = 6, 0.3, 0.3
        args.hold_phones, args.hold_seconds = 10, 8.0
        args.scaling_phones, args.scaling_seconds = 4, 3.0
    if args.burst_only:
        args.hold_phones, args.phone_servers, args.scaling_seconds = 0, 0, 0.0
    print(f"{args.phones} phones, think time 0-{args.think_max:g} s, wizard 0 (stress) and "
          f"0-{args.wizard_think:g} s; hold {args.hold_phones} phones for "
          f"{args.hold_seconds:g} s; baseline: bare FastAPI + SQLAlchemy app with the same "
          "writes and pushes (bench.baseline_app), run at the same moment")  # fmt: skip
    burst_load = args.phones if args.burst_load is None else args.burst_load
    report: dict[str, Any] = {"phones": args.phones, "think_max_s": args.think_max,
                              "wizard_think_s": args.wizard_think}  # fmt: skip
    with databases(args) as targets:
        for name, url, baseline_url in targets:
            load = os.getloadavg()
            ours, baseline = run_real(url, baseline_url, args.phones, args.think_max,
                                      args.wizard_think, args.seed, bursts=args.bursts,
                                      burst_only=args.burst_only,
                                      burst_load=burst_load)  # fmt: skip
            if name == "PostgreSQL" and args.phone_servers > 0:
                ours[SPLIT], baseline[SPLIT] = run_split(
                    url, baseline_url, args.phones, args.think_max, args.wizard_think,
                    args.seed, args.phone_servers)  # fmt: skip
            if args.hold_phones:
                ours["hold"], baseline["hold"] = server_hold.hold_both(
                    url, baseline_url, args.hold_phones, args.hold_seconds, args.think_max,
                    args.seed, args.wizard_think)  # fmt: skip
            if name == "PostgreSQL" and args.scaling_seconds > 0:
                ours["scaling"] = server_hold.scaling(url, args.scaling_phones,
                                                      args.scaling_seconds, args.seed)  # fmt: skip
            ours["load_before"], ours["load_after"] = load, os.getloadavg()
            report[name], report[f"{name} baseline"] = ours, baseline
            print_table(f"{name} (chameleons serve)", ours, baseline)
            print_table(f"{name}: baseline (bare FastAPI + SQLAlchemy, same moment)", baseline,
                        baseline)  # fmt: skip
            if args.hold_phones:
                server_hold.print_hold(name, ours["hold"], baseline["hold"])
            if "scaling" in ours:
                server_hold.print_scaling(name, ours["scaling"])
            print(f"load average (1, 5, 15 min) before: {_load(load)}; after: "
                  f"{_load(ours['load_after'])}; {os.cpu_count()} CPUs")  # fmt: skip
    report["goals"] = goals(report, args.hold_phones)
    failed = [f"{db}: {goal}" for db, checks in report["goals"].items()
              for goal, met in checks.items() if not met]  # fmt: skip
    print("\ngoals:", "all met" if not failed else "NOT met: " + "; ".join(failed))
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))
    return 0 if args.report_only or not failed else 1


def _load(values: Any) -> str:
    return ", ".join(f"{x:.2f}" for x in values)


if __name__ == "__main__":
    sys.exit(main())
