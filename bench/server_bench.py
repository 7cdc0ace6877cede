"""Server benchmark: participant phones against the real server, each figure beside the
same traffic against a bare FastAPI server (``bench.baseline_app``) measured in the same run.

``python -m bench.server_bench [--quick] [--phones 50] [--think-max 3] [--wizard-think 1]
[--hold-phones 200] [--hold-seconds 120] [--phone-servers 1] [--only sqlite|postgresql]
[--report-only]``

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
- **hold** (``bench.server_hold``): many phones (default 200) walk sessions back to back
  at the human pace for a fixed time, every socket held open.
- **think, paced, phone processes** (PostgreSQL, ``--phone-servers N``, default 1): the
  human-paced run again with the phones' links and sockets on N more server processes on
  the same database, the wizards and consoles on the main one (the deployment of docs/deployment.md,
  "More than one server process"): each answer reaches its console through LISTEN/NOTIFY.

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
import os
import random
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import Any

from bench import server_hold
from bench.server_load import Figures, Server, cpu_seconds, run_threads, scratch_postgres
from bench.server_walk import BaselinePhone, Pace, Phone, RealServer, submit_measured, walk_session

GOALS = {"think_update_p99_ms": 50.0, "burst_update_p99_ms": 500.0}
SCENARIOS = {"think_instant": "think, instant wizard (stress)",
             "think_paced": "think, human-paced wizard", "burst": "burst"}  # fmt: skip
# PostgreSQL only: the human-paced run with the phones on more server processes (docs/deployment.md,
# "More than one server process"); its baseline is the human-paced run's.
SPLIT, SPLIT_LABEL = "think_paced_split", "think, paced, phone processes"


def run_real(
    database_url: str, phones: int, think_max: float, wizard_think: float, seed: int
) -> dict[str, Any]:
    with Server.chameleons(database_url, sessions=3 * phones) as (server, setup):
        real = RealServer.of(server, setup)
        result = {name: walk_phones(real, phones, think_max, wizard_max, seed)
                  for name, wizard_max in (("think_instant", 0.0),
                                           ("think_paced", wizard_think))}  # fmt: skip
        result["burst"] = burst(real, phones)
        return result


def run_split(
    database_url: str, phones: int, think_max: float, wizard_think: float, seed: int,
    phone_servers: int,
) -> dict[str, Any]:  # fmt: skip
    """The human-paced run with every phone's link and socket on one of ``phone_servers``
    more ``chameleons serve`` processes on the same database (the wizards and consoles on
    the main one): each phone's answer reaches its console through PostgreSQL's
    LISTEN/NOTIFY, and the servers' CPU is that of all of them."""
    with Server.chameleons(database_url, sessions=phones,
                           phone_servers=phone_servers) as (server, setup):  # fmt: skip
        real = RealServer.of(server, setup)
        walked = walk_phones(real, phones, think_max, wizard_think, seed)
        return {**walked, "phone_servers": phone_servers}


def walk_phones(
    real: RealServer, phones: int, think_max: float, wizard_max: float, seed: int
) -> dict[str, Any]:
    """``phones`` new sessions walked at once, each at its own seeded pace; the figures,
    with the CPU of every server process the phones used."""
    figures, walkers = Figures(), [real.new_phone() for _ in range(phones)]
    paces = [Pace(random.Random(seed + i), think_max, wizard_max) for i in range(phones)]
    with server_cpu(real.server, figures, *real.phone_servers):
        run_threads([partial(walk_session, phone, figures, pace)
                     for phone, pace in zip(walkers, paces, strict=True)])  # fmt: skip
    for phone in walkers:
        real.release(phone, figures)
    return figures.summary()


def burst(real: RealServer, phones: int) -> dict[str, Any]:
    figures, waiting = Figures(), [real.new_phone() for _ in range(phones)]
    for phone in waiting:  # one after the other: the burst is the phones' alone
        phone.wizard.start()
        for to in ("discussion", "ranking"):
            phone.wizard.advance(1, to)
    with server_cpu(real.server, figures):
        run_threads([partial(submit_ranking, phone, figures) for phone in waiting],
                    together=True)  # fmt: skip
    for phone in waiting:
        real.release(phone, figures)
    return figures.summary()


@contextmanager
def server_cpu(server: Server, figures: Figures, *more: Server) -> Iterator[None]:
    """The server processes' CPU time over the block (``more``: the phone servers beside
    the main one), noted in ``figures`` (the wizard's actions of the think scenario are in
    it too: per submission, it is the servers' cost of a whole session divided by the
    phone's submissions)."""
    pids = [s.process.pid for s in (server, *more)]
    before, started = sum(map(cpu_seconds, pids)), time.monotonic()
    yield
    figures.server_cpu_s = sum(map(cpu_seconds, pids)) - before
    figures.seconds = time.monotonic() - started


def submit_ranking(phone: Phone, figures: Figures) -> None:
    ranking = [item["id"] for item in phone.participant.state()["items"]]
    submit_measured(figures, phone.console, partial(phone.participant.submit_ranking, 1, ranking))


def run_baseline(phones: int, submissions: int, think_max: float, seed: int) -> dict[str, Any]:
    """The same phones, sockets, submissions and think times against ``bench.baseline_app``
    (it has no wizard: its think scenario is the phones' part of either think run)."""
    with Server.baseline() as server:
        result = {}
        for name, count, pause, together in (("think", submissions, think_max, False),
                                             ("burst", 1, 0.0, True)):  # fmt: skip
            figures = Figures()
            phones_here = [BaselinePhone(server, f"{name}-{i}") for i in range(phones)]
            with server_cpu(server, figures):
                jobs = [partial(phone.submit, figures, count, Pace(random.Random(seed + i), pause))
                        for i, phone in enumerate(phones_here)]  # fmt: skip
                run_threads(jobs, together=together)
            for phone in phones_here:
                phone.close(figures)
            result[name] = figures.summary()
        result["think_instant"] = result["think_paced"] = result.pop("think")
        return result


@contextmanager
def databases(args: argparse.Namespace) -> Iterator[list[tuple[str, str]]]:
    with tempfile.TemporaryDirectory(prefix="chameleons-bench-") as tmp:
        found = (
            []
            if args.only == "postgresql"
            else [("SQLite", f"sqlite:///{Path(tmp) / 'bench.sqlite3'}")]
        )
        server_url = args.database_url or os.environ.get("TEST_DATABASE_URL")
        if args.only == "sqlite" or not server_url:
            yield found
            return
        with scratch_postgres(server_url) as url:
            yield [*found, ("PostgreSQL", url)]


def print_table(name: str, result: dict[str, Any], baseline: dict[str, Any]) -> None:
    print(f"\n{name}")
    print(f"{'scenario':<32} {'figure':<26} {'p50 ms':>8} {'p99 ms':>8} {'x base p99':>11} "
          "errors, dropped sockets")  # fmt: skip
    shown = {**SCENARIOS, **({SPLIT: SPLIT_LABEL} if SPLIT in result else {})}
    for scenario, label in shown.items():
        ours, base = result[scenario], baseline.get(scenario, baseline["think_paced"])
        for figure in ("http", "update"):
            p50, p99 = ours[f"{figure}_p50_ms"], ours[f"{figure}_p99_ms"]
            ratio = p99 / base[f"{figure}_p99_ms"] if base[f"{figure}_p99_ms"] else float("nan")
            what = "HTTP round trip" if figure == "http" else "submit -> console update"
            faults = f"{ours['errors']} {ours['dropped_sockets']}" if figure == "update" else ""
            print(f"{label:<32} {what:<26} {p50:>8.1f} {p99:>8.1f} {ratio:>10.1f}x {faults}")
        cpu, base_cpu = ours["server_cpu_ms_per_submission"], base["server_cpu_ms_per_submission"]
        ratio = f"{cpu / base_cpu:>10.1f}x" if base_cpu else f"{'n/a':>11}"  # 0: under a tick
        print(
            f"{label:<32} {'server CPU / submission':<26} {cpu:>8.1f} {'':>8} {ratio} "
            f"({ours['submissions']} submissions in {ours['seconds']:g} s)"
        )


def goals(report: dict[str, Any], hold_phones: int) -> dict[str, dict[str, bool]]:
    """Each database's goals, met or not; any error or dropped socket fails them."""
    found: dict[str, dict[str, bool]] = {}
    for name in ("SQLite", "PostgreSQL"):
        if name not in report:
            continue
        ours = report[name]
        checks = {
            "think p99 <= 50 ms (human-paced wizard)":
                ours["think_paced"]["update_p99_ms"] <= GOALS["think_update_p99_ms"],
            "burst p99 <= 500 ms": ours["burst"]["update_p99_ms"] <= GOALS["burst_update_p99_ms"],
            "no error or dropped socket in any scenario":
                not any(s["errors"] or s["dropped_sockets"]
                        for s in (ours[k] for k in (*SCENARIOS, SPLIT, "hold") if k in ours)),
        }  # fmt: skip
        if "hold" in ours:
            checks[f"{hold_phones} phones held"] = ours["hold"]["held"] >= hold_phones
        if SPLIT in ours:
            split = ours[SPLIT]
            checks[f"think p99 <= 50 ms, phones on {split['phone_servers']} more process(es)"] = (
                split["update_p99_ms"] <= GOALS["think_update_p99_ms"]
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
    found.add_argument("--phone-servers", type=int, default=1,
                       help="PostgreSQL: also run the human-paced scenario with the phones "
                            "on this many more server processes (0: not).")  # fmt: skip
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
    print(f"{args.phones} phones, think time 0-{args.think_max:g} s, wizard 0 (stress) and "
          f"0-{args.wizard_think:g} s; hold {args.hold_phones} phones for "
          f"{args.hold_seconds:g} s; baseline: bare FastAPI POST + WebSocket push "
          "(bench.baseline_app), same run")  # fmt: skip
    report: dict[str, Any] = {"phones": args.phones, "think_max_s": args.think_max,
                              "wizard_think_s": args.wizard_think}  # fmt: skip
    with databases(args) as targets:
        for name, url in targets:
            ours = run_real(url, args.phones, args.think_max, args.wizard_think, args.seed)
            if name == "PostgreSQL" and args.phone_servers > 0:
                ours[SPLIT] = run_split(url, args.phones, args.think_max, args.wizard_think,
                                        args.seed, args.phone_servers)  # fmt: skip
            submissions = max(1, round(ours["think_paced"]["submissions"] / args.phones))
            baseline = run_baseline(args.phones, submissions, args.think_max, args.seed)
            if args.hold_phones:
                hold_args = (args.hold_phones, args.hold_seconds, args.think_max, args.seed)
                ours["hold"] = server_hold.hold_real(url, *hold_args, args.wizard_think)
                baseline["hold"] = server_hold.hold_baseline(*hold_args)
            report[name], report[f"{name} baseline"] = ours, baseline
            print_table(f"{name} (chameleons serve)", ours, baseline)
            print_table(f"{name}: baseline (bare FastAPI)", baseline, baseline)
            if args.hold_phones:
                server_hold.print_hold(name, ours["hold"], baseline["hold"])
    report["goals"] = goals(report, args.hold_phones)
    failed = [f"{db}: {goal}" for db, checks in report["goals"].items()
              for goal, met in checks.items() if not met]  # fmt: skip
    print("\ngoals:", "all met" if not failed else "NOT met: " + "; ".join(failed))
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))
    return 0 if args.report_only or not failed else 1


if __name__ == "__main__":
    sys.exit(main())
