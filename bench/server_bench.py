"""Server benchmark: participant phones against the real server, each figure beside the
same traffic against a bare FastAPI server (``bench.baseline_app``) measured in the same run.

``python -m bench.server_bench [--quick] [--phones 50] [--think-max 3] [--database-url URL]``

The server under test is ``chameleons serve`` in a process of its own (as in a lab), on a
fresh SQLite file, or a fresh PostgreSQL database on ``--database-url``'s server (default:
``TEST_DATABASE_URL`` when set; ``--only sqlite|postgresql`` runs one). The load comes from this
process, one thread per phone:

- **think**: every phone walks a whole session (its wizard drives it over the staff API, as
  the console does; a console WebSocket per session is open all the time); before each of
  its submissions (rankings and questionnaire pages) the phone "thinks" a uniform 0..T s.
- **burst**: N more sessions wait at the ranking; all N phones submit at the same moment.

Figures per scenario: the phone's HTTP round trip and **submit -> console update** (from
just before the POST until the console's WebSocket delivers the event with the
submission's client id), p50/p99, and errors (any HTTP error, or no console update within
60 s). The baseline gets the same number of phones, submissions and think times, with an
HTTP endpoint that pushes each submission to a WebSocket and does nothing else.

Goals (issue 17): submit -> console p99 <= 50 ms at 50 phones with 0-3 s think time, and a
burst of 50 with no error and p99 <= 500 ms, on SQLite and PostgreSQL.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import secrets
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from bench.server_load import (
    Console,
    Figures,
    Server,
    cpu_seconds,
    run_threads,
    scratch_postgres,
)
from chameleons.backend.sessions.bot import (
    ApiError,
    ParticipantBot,
    StaffApi,
    WizardBot,
    answers_for,
)

UPDATE_TIMEOUT_S = 60.0
GOALS = {"think_update_p99_ms": 50.0, "burst_update_p99_ms": 500.0}


@dataclass
class Phone:
    """One participant: the phone's link, the session's wizard, the console socket."""

    wizard: WizardBot
    participant: ParticipantBot
    console: Console


@dataclass
class RealServer:
    server: Server
    staff_cookie: dict[str, str]
    csrf: str
    study_id: int
    phones: list[Phone] = field(default_factory=list)

    def new_phone(self) -> Phone:
        http = self.server.client(cookies=self.staff_cookie)
        staff = StaffApi(http)
        staff.csrf = self.csrf
        wizard = WizardBot.create(staff, self.study_id)
        phone = ParticipantBot(self.server.client(), wizard.token)
        console = Console(self.server.ws_url(f"/ws/wizard/sessions/{wizard.session_id}"),
                          self.server.base, self.staff_cookie)  # fmt: skip
        found = Phone(wizard, phone, console)
        self.phones.append(found)
        return found


Send = Callable[[str], Any]


def submit_measured(figures: Figures, console: Console, send: Send) -> Any:
    """One submission: its HTTP time, and the time until the console shows it."""
    client_id = secrets.token_urlsafe(12)
    start = console.clock()
    try:
        result = send(client_id)
    except ApiError as error:
        figures.count_error(f"HTTP {error.status} ({error.detail})")
        return None
    figures.add(http=console.clock() - start, update=None)
    arrived = console.wait_for(client_id, timeout=UPDATE_TIMEOUT_S)
    if arrived is None:
        figures.count_error(f"no console update within {UPDATE_TIMEOUT_S:g} s")
    else:
        figures.add(http=None, update=arrived - start)
    return result


def walk_session(phone: Phone, figures: Figures, rng: random.Random, think_max: float) -> None:
    """The whole session as ``drive_session`` walks it, measuring each phone submission; a
    wizard action the server refuses or fails ends this phone's walk, counted as an error."""
    try:
        _walk(phone, figures, rng, think_max)
    except ApiError as error:
        figures.count_error(f"wizard action: HTTP {error.status} ({error.detail})")


def _walk(phone: Phone, figures: Figures, rng: random.Random, think_max: float) -> None:
    wizard, participant = phone.wizard, phone.participant
    wizard.start()
    for position in range(1, wizard.snapshot["interaction_count"] + 1):
        for to in ("discussion", "ranking"):
            wizard.advance(position, to)
        ranking = [item["id"] for item in participant.state()["items"]]
        rng.shuffle(ranking)
        think(rng, think_max)
        submit_measured(figures, phone.console,
                        partial(participant.submit_ranking, position, ranking))  # fmt: skip
        wizard.advance(position, "negotiation")
        wizard.negotiate(position, lambda _s: rng.random() < 0.5)
        wizard.advance(position, "questionnaire")
        answer_pages(phone, figures, rng, think_max, position)
    answer_pages(phone, figures, rng, think_max, 0)


def answer_pages(phone: Phone, figures: Figures, rng: random.Random, think_max: float,
                 position: int) -> None:  # fmt: skip
    state = phone.participant.state()
    while state["view"] == "questionnaire" and state["position"] == position:
        questionnaire = state["questionnaire"]
        answers = answers_for(questionnaire, rng)
        think(rng, think_max)
        send = partial(phone.participant.submit_questionnaire, position, questionnaire["id"],
                       answers)  # fmt: skip
        receipt = submit_measured(figures, phone.console, send)
        if receipt is None:
            return
        state = receipt["state"]


def think(rng: random.Random, think_max: float) -> None:
    if think_max > 0:
        Console.pause(rng.uniform(0, think_max))


def run_real(database_url: str, phones: int, think_max: float, seed: int) -> dict[str, Any]:
    with Server.chameleons(database_url, sessions=2 * phones) as (server, setup):
        real = RealServer(server, setup["cookies"], setup["csrf"], setup["study_id"])
        think_figures, burst_figures = Figures(), Figures()
        walkers = [real.new_phone() for _ in range(phones)]
        with server_cpu(server, think_figures):
            run_threads([partial(walk_session, phone, think_figures, random.Random(seed + i),
                                 think_max) for i, phone in enumerate(walkers)])  # fmt: skip
        burst = [real.new_phone() for _ in range(phones)]
        for phone in burst:  # one after the other: the burst is the phones' alone
            phone.wizard.start()
            for to in ("discussion", "ranking"):
                phone.wizard.advance(1, to)
        with server_cpu(server, burst_figures):
            run_threads([partial(submit_ranking, phone, burst_figures) for phone in burst],
                        together=True)  # fmt: skip
        for phone in real.phones:
            phone.console.close()
        return {"think": think_figures.summary(), "burst": burst_figures.summary()}


@contextmanager
def server_cpu(server: Server, figures: Figures) -> Iterator[None]:
    """The server process's CPU time over the block, noted in ``figures`` (the wizard's
    actions of the think scenario are in it too: per submission, it is the server's cost of
    a whole session divided by the phone's submissions)."""
    before = cpu_seconds(server.process.pid)
    yield
    figures.server_cpu_s = cpu_seconds(server.process.pid) - before


def submit_ranking(phone: Phone, figures: Figures) -> None:
    ranking = [item["id"] for item in phone.participant.state()["items"]]
    submit_measured(figures, phone.console, partial(phone.participant.submit_ranking, 1, ranking))


@dataclass
class BaselinePhone:
    server: Server
    channel: str

    def __post_init__(self) -> None:
        self.console = Console(self.server.ws_url(f"/ws/{self.channel}"), self.server.base, {})
        self.http = self.server.client()

    def send(self, client_id: str) -> Any:
        return _post_json(self.http, f"/api/submit/{self.channel}", {"client_id": client_id})

    def submit(self, figures: Figures, count: int, pause: float, seed: int) -> None:
        rng = random.Random(seed)
        for _ in range(count):
            think(rng, pause)
            submit_measured(figures, self.console, self.send)

    def close(self) -> None:
        self.console.close()
        self.http.close()


def run_baseline(phones: int, submissions: int, think_max: float, seed: int) -> dict[str, Any]:
    """The same phones, submissions and think times against ``bench.baseline_app``."""
    with Server.baseline() as server:
        think_figures, burst_figures = Figures(), Figures()
        walkers = [BaselinePhone(server, f"think-{i}") for i in range(phones)]
        with server_cpu(server, think_figures):
            run_threads([partial(phone.submit, think_figures, submissions, think_max, seed + i)
                         for i, phone in enumerate(walkers)])  # fmt: skip
        burst = [BaselinePhone(server, f"burst-{i}") for i in range(phones)]
        with server_cpu(server, burst_figures):
            run_threads([partial(phone.submit, burst_figures, 1, 0.0, 0) for phone in burst],
                        together=True)  # fmt: skip
        for phone in walkers + burst:
            phone.close()
        return {"think": think_figures.summary(), "burst": burst_figures.summary()}


def _post_json(http: Any, path: str, body: dict[str, Any]) -> Any:
    response = http.post(path, json=body)
    if response.status_code >= 400:
        raise ApiError(response.status_code, response.text)
    return response.json()


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
    print(f"{'scenario':<8} {'figure':<26} {'p50 ms':>8} {'p99 ms':>8} {'x base p99':>11} errors")
    for scenario in ("think", "burst"):
        ours, base = result[scenario], baseline[scenario]
        for figure in ("http", "update"):
            p50, p99 = ours[f"{figure}_p50_ms"], ours[f"{figure}_p99_ms"]
            ratio = p99 / base[f"{figure}_p99_ms"] if base[f"{figure}_p99_ms"] else float("nan")
            label = "HTTP round trip" if figure == "http" else "submit -> console update"
            errors = ours["errors"] if figure == "update" else ""
            print(f"{scenario:<8} {label:<26} {p50:>8.1f} {p99:>8.1f} {ratio:>10.1f}x {errors}")
        cpu, base_cpu = ours["server_cpu_ms_per_submission"], base["server_cpu_ms_per_submission"]
        ratio = cpu / base_cpu if base_cpu else float("nan")
        print(f"{scenario:<8} {'server CPU / submission':<26} {cpu:>8.1f} {'':>8} {ratio:>10.1f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--phones", type=int, default=50)
    parser.add_argument("--think-max", type=float, default=3.0, help="Seconds (uniform 0..T).")
    parser.add_argument("--quick", action="store_true", help="10 phones, 0.5 s think time.")
    parser.add_argument("--database-url", default=None, help="PostgreSQL server to use.")
    parser.add_argument(
        "--only", choices=("sqlite", "postgresql"), default=None, help="Run one database only."
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, help="Also write the figures here.")
    args = parser.parse_args()
    if args.quick:
        args.phones, args.think_max = 10, 0.5
    print(f"{args.phones} phones, think time 0-{args.think_max:g} s; baseline: bare FastAPI "
          "POST + WebSocket push (bench.baseline_app), same run")  # fmt: skip
    report: dict[str, Any] = {"phones": args.phones, "think_max_s": args.think_max}
    with databases(args) as targets:
        for name, url in targets:
            report[name] = run_real(url, args.phones, args.think_max, args.seed)
            submissions = max(1, round(report[name]["think"]["submissions"] / args.phones))
            baseline = run_baseline(args.phones, submissions, args.think_max, args.seed)
            report[f"{name} baseline"] = baseline
            print_table(f"{name} (chameleons serve)", report[name], baseline)
            print_table(f"{name}: baseline (bare FastAPI)", baseline, baseline)
    goals = {name: {"think p99 <= 50 ms":
                    report[name]["think"]["update_p99_ms"] <= GOALS["think_update_p99_ms"],
                    "burst p99 <= 500 ms, no error":
                    report[name]["burst"]["update_p99_ms"] <= GOALS["burst_update_p99_ms"]
                    and not report[name]["burst"]["errors"]}
             for name in ("SQLite", "PostgreSQL") if name in report}  # fmt: skip
    report["goals"] = goals
    print("\ngoals:", json.dumps(goals))
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))
    sys.exit(0)


if __name__ == "__main__":
    main()
