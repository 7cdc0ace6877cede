"""The hold scenario of ``bench.server_bench``: many phones at once for a fixed time.

Every phone opens its session (the phone's socket ``/ws/p/{token}`` and the session's
console socket open), all wait at one barrier, then for ``seconds`` each walks sessions back
to back at the human pace (phone 0..T s before each submission, wizard 0..W s before each
action), opening a new session with its sockets when one ends. Figures: submit -> console
p50/p99, errors, sockets the server dropped, and the server process's CPU (share of one
core over the window) and resident memory (now and its peak). The baseline holds the same
number of sockets on ``bench.baseline_app`` and submits at the same think times.

The scaling scenario (``scaling``, PostgreSQL): the same walk with no pause at all (phone
and wizard instant, so the server is the limit), once on one server process and once with
the phones on a second process (the deployment of docs/deployment.md, "More than one server
process"); its figure is the second run's submissions per second over the first's.
"""

from __future__ import annotations

import math
import os
import random
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

from websockets.exceptions import WebSocketException

from bench.server_load import Figures, Server, cpu_seconds, memory_mib, run_threads
from bench.server_walk import BaselinePhone, Pace, RealServer, walk_session
from chameleons.backend.sessions.bot import ApiError

SETUP_ERRORS = (ApiError, OSError, TimeoutError, WebSocketException)


@dataclass
class Window:
    """The measured window: opened by the barrier's action once every phone is set up."""

    seconds: float
    pids: tuple[int, ...]  # the server processes whose CPU is the window's (the first's memory)
    deadline: float = math.inf
    started: float = 0.0
    cpu_before: float = 0.0
    together: threading.Barrier | None = None  # the other server's window opens with this one

    def open(self) -> None:
        if self.together is not None:
            self.together.wait()
        self.started = time.monotonic()
        self.deadline = self.started + self.seconds
        self.cpu_before = sum(map(cpu_seconds, self.pids))

    def close(self, figures: Figures, phones: int, held: int, sockets: int) -> dict[str, Any]:
        wall = time.monotonic() - self.started
        figures.server_cpu_s = sum(map(cpu_seconds, self.pids)) - self.cpu_before
        figures.seconds = wall
        return {**figures.summary(), "phones": phones, "held": held, "sockets_opened": sockets,
                "server_cpu_share": round(figures.server_cpu_s / wall, 3) if wall else 0.0,
                **memory_mib(self.pids[0])}  # fmt: skip


def _with_barrier(barrier: threading.Barrier, figures: Figures, setup: Callable[[], Any],
                  walk: Callable[[Any], None]) -> None:  # fmt: skip
    """Set up, wait for every phone, then walk; a phone whose setup failed (an error of the
    scenario) still meets the barrier, or the others would wait for it forever."""
    try:
        ready = setup()
    except SETUP_ERRORS as error:
        figures.count_error(f"opening a session: {error!r}")
        barrier.wait()
        return
    except BaseException:
        barrier.wait()
        raise
    barrier.wait()
    walk(ready)


def hold_real(database_url: str, phones: int, seconds: float, think_max: float, seed: int,
              wizard_think: float, together: threading.Barrier | None = None,
              phone_servers: int = 0) -> dict[str, Any]:  # fmt: skip
    # Paced sessions last longer than 4 s; instant ones (the scaling runs) about a second.
    rows = phones * max(3, math.ceil(seconds / (4 if think_max else 0.5)))
    with Server.chameleons(database_url, sessions=rows,
                           phone_servers=phone_servers) as (server, setup):  # fmt: skip
        real = RealServer.of(server, setup)
        pids = tuple(s.process.pid for s in (server, *real.phone_servers))
        figures, window = Figures(), Window(seconds, pids, together=together)
        barrier = threading.Barrier(phones, action=window.open)
        held: list[int] = []  # phones that were still there at the window's end

        def walk(index: int, first: Any) -> None:
            pace = Pace(random.Random(seed + index), think_max, wizard_think, window.deadline)
            phone = first
            while True:
                walk_session(phone, figures, pace)
                real.release(phone, figures)
                if time.monotonic() >= window.deadline:
                    held.append(index)
                    return
                try:
                    phone = real.new_phone()
                except SETUP_ERRORS as error:
                    figures.count_error(f"new session: {error!r}")
                    return

        run_threads([partial(_with_barrier, barrier, figures, real.new_phone_alone,
                             partial(walk, i))
                     for i in range(phones)])  # fmt: skip
        return window.close(figures, phones, len(held), real.sockets_opened)


def hold_baseline(phones: int, seconds: float, think_max: float, seed: int,
                  database_url: str | None = None,
                  together: threading.Barrier | None = None) -> dict[str, Any]:  # fmt: skip
    with Server.baseline(database_url) as server:
        figures, window = Figures(), Window(seconds, (server.process.pid,), together=together)
        barrier = threading.Barrier(phones, action=window.open)
        held: list[int] = []

        def walk(index: int, phone: BaselinePhone) -> None:
            pace = Pace(random.Random(seed + index), think_max, 0.0, window.deadline)
            phone.submit(figures, math.inf, pace)
            phone.close(figures)
            held.append(index)

        run_threads([partial(_with_barrier, barrier, figures,
                             partial(BaselinePhone, server, f"hold-{i}"), partial(walk, i))
                     for i in range(phones)])  # fmt: skip
        return window.close(figures, phones, len(held), 2 * phones)


def hold_both(database_url: str, baseline_url: str, phones: int, seconds: float,
              think_max: float, seed: int, wizard_think: float,
              ) -> tuple[dict[str, Any], dict[str, Any]]:  # fmt: skip
    """The hold on the real server and on the baseline app at the same moment: each sets up
    its phones, then both windows open together."""
    together, found = threading.Barrier(2), {}

    def real() -> None:
        found["real"] = hold_real(database_url, phones, seconds, think_max, seed,
                                  wizard_think, together)  # fmt: skip

    def baseline() -> None:
        found["baseline"] = hold_baseline(phones, seconds, think_max, seed, baseline_url,
                                          together)  # fmt: skip

    run_threads([real, baseline])
    return found["real"], found["baseline"]


def scaling(database_url: str, phones: int, seconds: float, seed: int) -> dict[str, Any]:
    """``phones`` walking sessions with no pause for ``seconds`` on one server process, then
    with the phones on a second one: each run's figures and the throughput's ratio."""
    one = hold_real(database_url, phones, seconds, 0.0, seed, 0.0)
    two = hold_real(database_url, phones, seconds, 0.0, seed, 0.0, phone_servers=1)
    rates = [run["submissions"] / run["seconds"] if run["seconds"] else 0.0 for run in (one, two)]
    return {"phones": phones, "one": one, "two": two,
            "submissions_per_s": [round(rate, 1) for rate in rates],
            "throughput_ratio": round(rates[1] / rates[0], 3) if rates[0] else 0.0}  # fmt: skip


def print_scaling(name: str, found: dict[str, Any]) -> None:
    one, two = found["one"], found["two"]
    print(f"\n{name}: scaling, {found['phones']} phones with no pause, one server process "
          "against two (the phones on the second)")  # fmt: skip
    print(f"{'figure':<34} {'one process':>12} {'two':>10}")
    rate_one, rate_two = found["submissions_per_s"]
    print(f"{'phone submissions per second':<34} {rate_one:>12.1f} {rate_two:>10.1f}")
    print(f"{'servers CPU, share of a core':<34} {one['server_cpu_share']:>12.2f} "
          f"{two['server_cpu_share']:>10.2f}")  # fmt: skip
    print(f"{'submit -> console state p99 ms':<34} {one['state_p99_ms']:>12.1f} "
          f"{two['state_p99_ms']:>10.1f}")  # fmt: skip
    print(f"{'errors':<34} {one['errors'] or 0} / {two['errors'] or 0}")
    print(f"throughput, two processes over one: {found['throughput_ratio']:.2f}x "
          f"({os.cpu_count()} CPUs on this machine, the load generator and PostgreSQL among "
          "them)")  # fmt: skip


def print_hold(name: str, ours: dict[str, Any], base: dict[str, Any]) -> None:
    print(
        f"\n{name}: hold, {ours['phones']} phones for {ours['seconds']:g} s "
        f"({ours['sockets_opened']} sockets opened; baseline {base['sockets_opened']})"
    )
    print(f"{'figure':<30} {'chameleons':>12} {'baseline':>10} {'ratio':>7}")
    rows = [("submit -> console state p50 ms", "state_p50_ms", "{:.1f}"),
            ("submit -> console state p99 ms", "state_p99_ms", "{:.1f}"),
            ("submit -> event p99 ms", "update_p99_ms", "{:.1f}"),
            ("HTTP p99 ms", "http_p99_ms", "{:.1f}"),
            ("server CPU ms / submission", "server_cpu_ms_per_submission", "{:.1f}"),
            ("server CPU, share of a core", "server_cpu_share", "{:.2f}"),
            ("server RSS MiB (end)", "rss_mib", "{:.0f}"),
            ("server RSS MiB (peak)", "peak_rss_mib", "{:.0f}")]  # fmt: skip
    # The baseline has no wizard, so its phones submit more often: no ratio for the count.
    print(f"{'submissions':<30} {ours['submissions']:>12} {base['submissions']:>10}")
    for label, key, shape in rows:
        ratio = f"{ours[key] / base[key]:>6.1f}x" if base[key] else f"{'n/a':>7}"
        print(f"{label:<30} {shape.format(ours[key]):>12} {shape.format(base[key]):>10} {ratio}")
    print(f"{'errors':<30} {ours['errors']} (baseline {base['errors']})")
    print(f"{'dropped sockets':<30} {ours['dropped_sockets']} "
          f"(baseline {base['dropped_sockets']})")  # fmt: skip
