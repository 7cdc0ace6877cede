"""The burst scenarios of ``bench.server_bench``: N sessions wait at the ranking and their N
phones submit at one barrier, beside N phones of the baseline app at the same barrier.

- ``burst``: the bursts alone, ``rounds`` times; the servers' CPU over the bursts is the
  CPU-per-submission goal's figure (both servers do the same submissions and nothing else).
- ``burst_under_load``: one more burst while the bench's standard load runs: as many
  phones as the think scenario's, walking sessions at the human pace with their wizards
  (and as many baseline phones submitting at the same think times). Its p99 is judged
  against the same 500 ms goal; its CPU is not judged (the load's is in it).
"""

from __future__ import annotations

import random
import threading
import time
from functools import partial
from typing import Any

from bench.server_load import Figures, Server, run_threads, server_cpu
from bench.server_walk import BaselinePhone, Pace, Phone, RealServer, submit_measured, walk_session

WARM_UP_CAP_S = 30.0  # the load's first submissions come within its think time; at most this


def burst(
    real: RealServer, base: Server, phones: int, rounds: int = 1,
) -> tuple[dict[str, Any], dict[str, Any]]:  # fmt: skip
    """N sessions waiting at the ranking submit at one barrier, with N baseline phones;
    ``rounds`` times (new sessions each time), the CPU of all rounds added up."""
    figures, theirs = Figures(), Figures()
    for round_ in range(rounds):
        waiting, rankings = at_the_ranking(real, phones)
        beside = [BaselinePhone(base, f"burst-{round_}-{i}") for i in range(phones)]
        cpu, seconds = (figures.server_cpu_s, theirs.server_cpu_s), figures.seconds
        with server_cpu(real.server, figures), server_cpu(base, theirs):
            _submit_together(waiting, rankings, beside, figures, theirs)
        figures.server_cpu_s += cpu[0]
        theirs.server_cpu_s += cpu[1]
        figures.seconds += seconds
        theirs.seconds = figures.seconds
        _release(real, waiting, beside, figures, theirs)
    return figures.summary(), theirs.summary()


def burst_under_load(
    real: RealServer, base: Server, phones: int, load: int, think_max: float,
    wizard_max: float, seed: int,
) -> tuple[dict[str, Any], dict[str, Any]]:  # fmt: skip
    """One burst of ``phones`` while ``load`` phones walk sessions at the human pace (and
    as many baseline phones submit at the same think times); the burst's figures. The
    burst waits until the load has made about one submission a phone."""
    figures, theirs, busy, their_busy = Figures(), Figures(), Figures(), Figures()
    waiting, rankings = at_the_ranking(real, phones)
    beside = [BaselinePhone(base, f"loaded-burst-{i}") for i in range(phones)]
    walkers = [real.new_phone_alone() for _ in range(load)]
    loaders = [BaselinePhone(base, f"load-{i}") for i in range(load)]
    stop = threading.Event()

    def walk(index: int, phone: Phone) -> None:
        # One session each: at the human pace it outlasts the burst by far; a phone done
        # sooner (no think time: the smoke test) waits for the burst's end with it open.
        pace = Pace(random.Random(seed + 1000 + index), think_max, wizard_max, stop=stop)
        walk_session(phone, busy, pace)
        stop.wait()
        real.release(phone, busy)

    def submit(index: int, phone: BaselinePhone) -> None:
        phone.submit(their_busy, float("inf"),
                     Pace(random.Random(seed + 1000 + index), think_max, stop=stop))  # fmt: skip
        phone.close(their_busy)

    def the_burst() -> None:
        try:
            cap = time.monotonic() + min(WARM_UP_CAP_S, 2 * think_max + 5)
            while len(busy.http) < load and time.monotonic() < cap:
                time.sleep(0.05)  # a bench's wait for its own load, not a test's
            with server_cpu(real.server, figures), server_cpu(base, theirs):
                _submit_together(waiting, rankings, beside, figures, theirs)
        finally:
            stop.set()

    run_threads([the_burst, *(partial(walk, i, p) for i, p in enumerate(walkers)),
                 *(partial(submit, i, p) for i, p in enumerate(loaders))])  # fmt: skip
    _release(real, waiting, beside, figures, theirs)
    found = figures.summary()
    # The load's faults are the scenario's too: the server made them while the burst ran.
    load_figures = busy.summary()
    for kind in ("errors", "dropped_sockets"):
        found[kind].update({f"load: {what}": n for what, n in load_figures[kind].items()})
    found["load"] = {"phones": load, "submissions": load_figures["submissions"]}
    return found, theirs.summary()


def at_the_ranking(real: RealServer, phones: int) -> tuple[list[Phone], list[list[str]]]:
    """``phones`` new sessions, each at its first ranking, and the items each will rank."""
    waiting = [real.new_phone() for _ in range(phones)]
    for phone in waiting:  # one after the other: the burst is the phones' alone
        phone.wizard.start()
        for to in ("discussion", "ranking"):
            phone.wizard.advance(1, to)
    # The items to rank, read before the barrier: a phone page has them from its socket
    # (the view pushed when the wizard opened the ranking) and sends only its answer.
    return waiting, [_items(phone) for phone in waiting]


def _submit_together(waiting: list[Phone], rankings: list[list[str]],
                     beside: list[BaselinePhone], figures: Figures,
                     theirs: Figures) -> None:  # fmt: skip
    run_threads([*(partial(submit_ranking, phone, figures, ranking)
                   for phone, ranking in zip(waiting, rankings, strict=True)),
                 *(partial(submit_measured, theirs, other.console, other.send)
                   for other in beside)], together=True)  # fmt: skip


def _release(real: RealServer, waiting: list[Phone], beside: list[BaselinePhone],
             figures: Figures, theirs: Figures) -> None:  # fmt: skip
    for phone in waiting:
        real.release(phone, figures)
    for other in beside:
        other.close(theirs)


def _items(phone: Phone) -> list[str]:
    return [item["id"] for item in phone.participant.state()["items"]]


def submit_ranking(phone: Phone, figures: Figures, ranking: list[str]) -> None:
    submit_measured(figures, phone.console, partial(phone.participant.submit_ranking, 1, ranking))
