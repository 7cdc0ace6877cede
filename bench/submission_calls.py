"""The work of one ranking submission, counted: Python calls, C calls and SQL statements
per submission of the real app, beside the bare app's (``bench/baseline_app.py``) counted
the same way in the same run.

Counts do not depend on the machine's load, so they show a cut on a shared machine where
the CPU figures of ``bench.server_bench --burst-only`` move by less than their noise
(docs/performance.md, "CPU per participant submission: the burst alone"). They are the
request's own work only: both apps run in this process (Starlette's ``TestClient``, a
fresh SQLite file each) with no WebSocket open, so nothing is pushed and nothing runs on
a timer; the burst bench measures the rest. Every thread but this one is counted (the
client's own calls run on this thread), from the request's arrival to its answer. The real
app's ranking is counted at the first interaction and at the last, whose session has more
stored (suggestions, answers). A wizard's decision (interaction 1's first suggestion:
the decision, the next proposal, their two events) is counted too: the wizards' actions
were the largest share of a held server's CPU (docs/performance.md, "Where the rest is").

    python -m bench.submission_calls [--submissions 30] [--quick] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import random
import secrets
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

from sqlalchemy import event


@dataclass
class Counts:
    python_calls: int = 0
    c_calls: int = 0
    statements: int = 0
    cpu_s: float = 0.0  # process CPU over the counted requests (with the profiler's cost)

    def per(self, submissions: int) -> dict[str, float]:
        return {"python_calls": self.python_calls / submissions,
                "c_calls": self.c_calls / submissions,
                "statements": self.statements / submissions,
                "cpu_ms": 1000 * self.cpu_s / submissions}  # fmt: skip


class Counter:
    """Calls of every thread but the one that made it, while ``on``."""

    def __init__(self) -> None:
        self.counts = Counts()
        self.on = False
        self._client = threading.get_ident()
        self._lock = threading.Lock()

    def profile(self, _frame: Any, what: str, _arg: Any) -> None:
        if not self.on or threading.get_ident() == self._client:
            return
        with self._lock:
            if what == "call":
                self.counts.python_calls += 1
            elif what == "c_call":
                self.counts.c_calls += 1

    def statement(self, *_args: Any) -> None:
        if self.on:
            self.counts.statements += 1

    @contextmanager
    def counting(self) -> Iterator[None]:
        started = time.process_time()
        self.on = True
        try:
            yield
        finally:
            self.on = False
            self.counts.cpu_s += time.process_time() - started


@contextmanager
def profiled(counter: Counter) -> Iterator[None]:
    """Threads started inside the block are counted (the client's portal, the pool's)."""
    threading.setprofile(counter.profile)
    try:
        yield
    finally:
        threading.setprofile(None)


def _accept(rng: random.Random, _suggestion: Any) -> bool:
    return rng.random() < 0.5


def count_real(submissions: int, tmp: Path, position: int = 1, decision: bool = False) -> Counts:
    """``submissions`` sessions, each walked to interaction ``position``'s ranking (the
    interactions before it done in full: ranked, negotiated, questionnaires answered);
    then each phone's ranking, counted. With ``decision``, the ranking is not counted; the
    wizard's decision on that interaction's first suggestion is. One session more is walked
    the same way and its request is not counted: the warm-up the bare app has too (a
    route's first request is slower: FastAPI reads its endpoint's source once)."""
    from fastapi.testclient import TestClient

    from bench.server_load import _prepare
    from chameleons.backend.app import create_app
    from chameleons.backend.sessions.bot import ParticipantBot, StaffApi, WizardBot
    from chameleons.settings import Settings

    # A database of its own per count: the decision's is not the ranking's at position 1.
    name = f"{'decision' if decision else 'ranking'}-{position}"
    url = f"sqlite:///{tmp / f'real-{name}.sqlite3'}"
    study_ids, username, password = _prepare(url, submissions + 1, "wizard")
    settings = Settings(database_url=url, data_dir=tmp / f"data-{name}", bridge_enabled=False,
                        secret_key=secrets.token_urlsafe(32), _env_file=None)  # fmt: skip
    app = create_app(settings)
    counter = Counter()
    event.listen(app.state.engine, "before_cursor_execute", counter.statement)
    with profiled(counter), TestClient(app) as http:
        staff = StaffApi(http).login(username, password)
        waiting = []
        for i in range(submissions + 1):  # the first: the warm-up
            wizard = WizardBot.create(staff, study_ids[i % len(study_ids)])
            wizard.start()
            phone = ParticipantBot(http, wizard.token)
            rng = random.Random(i)
            for before in range(1, position):
                for to in ("discussion", "ranking"):
                    wizard.advance(before, to)
                phone.rank(rng)
                wizard.advance(before, "negotiation")
                wizard.negotiate(before, partial(_accept, rng))
                wizard.advance(before, "questionnaire")
                phone.answer_questionnaires(before, rng)
            for to in ("discussion", "ranking"):
                wizard.advance(position, to)
            waiting.append((phone, [item["id"] for item in phone.state()["items"]]))
            if decision:
                phone.submit_ranking(position, waiting[-1][1])
                wizard.advance(position, "negotiation")
                with counter.counting() if i else nullcontext():
                    wizard.decide(position, 1, True)
        # A phone has no staff login: the staff cookie the client kept goes (else every
        # counted request would decode it). The client's own calls are on this thread.
        http.cookies.clear()
        counted = [] if decision else waiting  # the decisions were counted as they came
        for i, (phone, ranking) in enumerate(counted):
            with counter.counting() if i else nullcontext():
                phone.submit_ranking(position, ranking)
    app.state.engine.dispose()
    return counter.counts


def count_bare(submissions: int, tmp: Path) -> Counts:
    from fastapi.testclient import TestClient

    from bench import baseline_app

    # Its engine on a file of this run's own (the app reads the module's at each request).
    before, engine = baseline_app.ENGINE, baseline_app._engine(f"sqlite:///{tmp / 'bare.sqlite3'}")
    baseline_app.ENGINE = engine
    counter = Counter()
    event.listen(engine, "before_cursor_execute", counter.statement)
    try:
        with profiled(counter), TestClient(baseline_app.app) as http:
            http.post("/api/submit/warm-up", json={"client_id": "warm-up"}).raise_for_status()
            for i in range(submissions):
                body = {"client_id": secrets.token_urlsafe(16),
                        "answers": {"ranking": list("abc")}}  # fmt: skip
                with counter.counting():
                    http.post(f"/api/submit/phone-{i}", json=body).raise_for_status()
    finally:
        baseline_app.ENGINE = before
        engine.dispose()
    return counter.counts


POSITIONS = (1, 3)  # the default study's first and last interaction


def measure(
    submissions: int, positions: tuple[int, ...] = POSITIONS, decision: bool = True
) -> dict[str, Any]:
    """The real app's ranking at each of ``positions`` (the first: no suggestion or
    interaction's answers stored yet; a later one reads those of the ones before), the
    bare app's submission, which is the same at every position, and (``decision``) a
    wizard's decision."""
    with tempfile.TemporaryDirectory(prefix="chameleons-calls-") as tmp:
        bare = count_bare(submissions, Path(tmp)).per(submissions)
        found: dict[str, Any] = {"submissions": submissions, "bare": bare, "positions": {}}
        for position in positions:
            real = count_real(submissions, Path(tmp), position).per(submissions)
            found["positions"][str(position)] = _compared(real, bare)
        if decision:
            real = count_real(submissions, Path(tmp), 1, decision=True).per(submissions)
            found["decision"] = _compared(real, bare)
    return found


def _compared(real: dict[str, float], bare: dict[str, float]) -> dict[str, Any]:
    return {"real": real, "ratio": {key: real[key] / bare[key] for key in real if bare[key]}}


def report(result: dict[str, Any], out: Callable[[str], Any] = print) -> None:
    out(f"Per ranking submission ({result['submissions']} each, SQLite, no socket open):")
    positions = result["positions"]
    header = "".join(f"{'interaction ' + p:>22}" for p in positions)
    out(f"{'':14}{'bare app':>10}{header}")
    for key, label in (("python_calls", "Python calls"), ("c_calls", "C calls"),
                       ("statements", "statements"), ("cpu_ms", "CPU ms *")):  # fmt: skip
        shown = "".join(f"{found['real'][key]:12.1f} ({found['ratio'].get(key, 0):4.2f}x)"
                        for found in positions.values())  # fmt: skip
        out(f"{label:14}{result['bare'][key]:10.1f}{shown}")
    if "decision" in result:
        found = result["decision"]
        out("A wizard's decision (interaction 1, suggestion 1; the next proposal; two events):")
        for key, label in (("python_calls", "Python calls"), ("c_calls", "C calls"),
                           ("statements", "statements")):  # fmt: skip
            out(f"{label:14}{found['real'][key]:10.1f} ({found['ratio'].get(key, 0):4.2f}x "
                "the bare submission)")  # fmt: skip
    out("(x: the real app's figure over the bare app's)")
    out("* with the profiler's own cost: a rough figure; the counts are the measure.")


def parser() -> argparse.ArgumentParser:
    found = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    found.add_argument("--submissions", type=int, default=30)
    found.add_argument("--quick", action="store_true", help="5 submissions a side")
    found.add_argument("--json", type=Path, help="write the figures to this file")
    return found


def main(argv: list[str] | None = None) -> int:
    arguments = parser()
    args = arguments.parse_args(argv)
    if args.submissions < 1:
        arguments.error("--submissions must be at least 1")
    result = measure(5 if args.quick else args.submissions)
    report(result)
    if args.json:
        args.json.write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
