"""Speech benchmark: wizard click -> speech start at the robot, against a bare WebSocket
round trip measured in the same run.

``python -m bench.speech_bench [--quick] [--plays 50] [--robot virtual|furhat] [--json FILE]``

``chameleons serve`` runs in a process of its own with its worker link on (loopback ZeroMQ
ports of this run) on a fresh SQLite file; for each robot a real ``chameleons worker``
process connects to it (``bench.speech_robots``): the **virtual** robot (the booth's
display page in headless Chromium) and the **Furhat** test peer. The wizard plays the
prompt group ``ack_yes`` through the console's API (``POST
/api/wizard/sessions/{id}/prompts/play``, as a click on the console does), one play at a
time, each after the previous one ended (a first play warms up and is not counted).

Figures per robot, p50/p99 in ms from just before the wizard's request:

- **ack**: the request's answer (the server logged the click and the worker acknowledged);
- **speech start at the robot**: the display page's audio started playing (its report to
  the server) / the Furhat said ``response.speak.start``;
- **speech start on the console**: the console's WebSocket delivered the logged
  ``prompt.speech_start`` event (the robot's report went back through the worker).

The baseline: a bare WebSocket round trip (a text message to ``bench.baseline_app``'s
``/echo`` and back) from this process, in the same run; ratios are set against its p50
and p99. The Furhat peer adds no start latency of its own (a real robot's is its own).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from websockets.sync.client import connect

from bench import speech_robots
from bench.server_load import Listener, Server, free_port, percentile
from chameleons.backend.sessions.bot import ApiError, StaffApi, WizardBot

GROUP = "ack_yes"
ROBOTS = ("virtual", "furhat")
FIGURES = {"ack": "click -> ack", "robot": "click -> speech start at the robot",
           "console": "click -> speech start on the console"}  # fmt: skip


def echo_round_trips(count: int) -> list[float]:
    """Seconds of ``count`` bare WebSocket round trips to the baseline app."""
    with Server.baseline() as server, connect(server.ws_url("/echo"), proxy=None) as socket:
        trips = []
        for index in range(count + 1):
            start = time.perf_counter()
            socket.send(f"ping {index}")
            socket.recv(timeout=speech_robots.WAIT_S)
            if index:  # the first opens the way (buffers, the server's first receive)
                trips.append(time.perf_counter() - start)
        return trips


@contextmanager
def robot_of(name: str, server: Server, setup: dict[str, Any], booth: str) -> Iterator[Any]:
    if name == "virtual":
        with speech_robots.display_page(server.base, setup["secret_key"], booth) as page:
            yield page
    else:
        with speech_robots.furhat() as peer:
            yield peer


class Plays:
    """One robot's plays: the figures in seconds, and what went wrong."""

    def __init__(self) -> None:
        self.times: dict[str, list[float]] = {key: [] for key in FIGURES}
        self.uncertainty: list[float] = []
        self.errors: Counter[str] = Counter()

    def summary(self, baseline: dict[str, float]) -> dict[str, Any]:
        found: dict[str, Any] = {"plays": len(self.times["ack"]), "errors": dict(self.errors)}
        for key, values in self.times.items():
            for label, q in (("p50", 0.5), ("p99", 0.99)):
                ms = percentile(values, q) * 1000
                found[f"{key}_{label}_ms"] = round(ms, 2)
                found[f"{key}_{label}_x_baseline"] = round(ms / baseline[f"{label}_ms"], 1)
        if self.uncertainty:
            found["clock_uncertainty_max_ms"] = round(max(self.uncertainty), 2)
        return found


def play_once(staff: StaffApi, wizard: WizardBot, console: Listener,
              robot: speech_robots.Robot, plays: Plays | None) -> None:  # fmt: skip
    """One click and its speech; ``plays`` None: a warm-up, whose failure stops the run."""
    robot.before_play()
    start = time.perf_counter()
    try:
        result = staff.post(f"/api/wizard/sessions/{wizard.session_id}/prompts/play",
                            {"group": GROUP})  # fmt: skip
    except ApiError as error:
        return _failed(plays, f"play: HTTP {error.status} ({error.detail})")
    acked = time.perf_counter()
    if not result["sent"]:
        return _failed(plays, f"not sent: {result['reason']} ({result['detail']})")
    spoke = robot.speech_start(result["prompt_id"])
    shown = console.wait_for(f"prompt.speech_start:{result['event_id']}", speech_robots.WAIT_S)
    # The next click waits for this prompt's end, as a wizard does.
    ended = console.wait_for(f"prompt.speech_end:{result['event_id']}", speech_robots.WAIT_S)
    if spoke is None or shown is None or ended is None:
        missing = "the robot's start" if spoke is None else "the console's start or end"
        return _failed(plays, f"no {missing} within {speech_robots.WAIT_S:g} s")
    if plays is not None:
        for key, moment in (("ack", acked), ("robot", spoke), ("console", shown)):
            plays.times[key].append(moment - start)
        plays.uncertainty.append(robot.clock_uncertainty_ms())


def _failed(plays: Plays | None, what: str) -> None:
    if plays is None:
        raise RuntimeError(f"the warm-up play failed: {what}")
    plays.errors[what] += 1


def wait_for_worker(staff: StaffApi, study_id: int, booth: str) -> None:
    deadline = time.monotonic() + speech_robots.WAIT_S * 4
    while time.monotonic() < deadline:
        monitor = staff.get(f"/api/pi/monitor?study={study_id}")
        if any(b["booth"] == booth and b["worker_connected"] for b in monitor["booths"]):
            return
        Listener.pause(0.1)
    raise RuntimeError(f"the worker of {booth} never connected to the server")


def measure(server: Server, setup: dict[str, Any], name: str, count: int, tmp: Path,
            endpoints: tuple[str, str], baseline: dict[str, float]) -> dict[str, Any]:  # fmt: skip
    booth = f"bench-{name}"
    staff = StaffApi(server.client(cookies=setup["cookies"]))
    staff.csrf = setup["csrf"]
    study_id = setup["study_ids"][0]
    wizard = WizardBot.create(staff, study_id, booth=booth)
    console = Listener(server.ws_url(f"/ws/wizard/sessions/{wizard.session_id}"), server.base,
                       setup["cookies"])  # fmt: skip
    plays = Plays()
    try:
        with (robot_of(name, server, setup, booth) as robot,
              speech_robots.worker(booth, robot, endpoints, tmp)):  # fmt: skip
            wait_for_worker(staff, study_id, booth)
            play_once(staff, wizard, console, robot, None)
            for _ in range(count):
                play_once(staff, wizard, console, robot, plays)
    finally:
        console.close()
        staff.http.close()
    return plays.summary(baseline)


def run(count: int, robots: tuple[str, ...]) -> dict[str, Any]:
    trips = echo_round_trips(max(count, 50))
    baseline = {"p50_ms": percentile(trips, 0.5) * 1000, "p99_ms": percentile(trips, 0.99) * 1000}
    report: dict[str, Any] = {"plays": count, "baseline_ws_round_trip":
                              {k: round(v, 3) for k, v in baseline.items()}}  # fmt: skip
    endpoints = (f"tcp://127.0.0.1:{free_port()}", f"tcp://127.0.0.1:{free_port()}")
    env = {"CHAMELEONS_BRIDGE_ENABLED": "true", "CHAMELEONS_WORKER_COMMAND_ENDPOINT": endpoints[0],
           "CHAMELEONS_WORKER_TELEMETRY_ENDPOINT": endpoints[1]}  # fmt: skip
    with tempfile.TemporaryDirectory(prefix="chameleons-speech-") as folder:
        tmp = Path(folder)
        url = f"sqlite:///{tmp / 'bench.sqlite3'}"
        with Server.chameleons(url, sessions=len(robots), role="pi", env=env) as (server, setup):
            for name in robots:
                report[name] = measure(server, setup, name, count, tmp, endpoints, baseline)
    return report


def print_report(report: dict[str, Any]) -> None:
    base = report["baseline_ws_round_trip"]
    print(f"baseline: bare WebSocket round trip p50 {base['p50_ms']:.2f} ms, "
          f"p99 {base['p99_ms']:.2f} ms")  # fmt: skip
    print(f"{'robot':<8} {'figure':<38} {'p50 ms':>8} {'x base':>7} {'p99 ms':>8} {'x base':>7}")
    for name in ROBOTS:
        if name not in report:
            continue
        ours = report[name]
        for key, label in FIGURES.items():
            print(f"{name:<8} {label:<38} {ours[f'{key}_p50_ms']:>8.1f} "
                  f"{ours[f'{key}_p50_x_baseline']:>6.1f}x {ours[f'{key}_p99_ms']:>8.1f} "
                  f"{ours[f'{key}_p99_x_baseline']:>6.1f}x")  # fmt: skip
        extra = ours.get("clock_uncertainty_max_ms")
        clock = f"; page clock mapped to within {extra:.2f} ms" if extra else ""
        print(f"{name:<8} {ours['plays']} plays, errors {ours['errors']}{clock}")


def parser() -> argparse.ArgumentParser:
    found = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    found.add_argument("--plays", type=int, default=50, help="Counted plays per robot.")
    found.add_argument("--robot", choices=ROBOTS, action="append",
                       help="Only this robot (repeatable); default: both.")  # fmt: skip
    found.add_argument("--quick", action="store_true", help="10 plays per robot.")
    found.add_argument("--json", type=Path, help="Also write the figures here.")
    return found


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if args.quick:
        args.plays = 10
    report = run(args.plays, tuple(args.robot or ROBOTS))
    print_report(report)
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))
    failed = [name for name in ROBOTS if report.get(name, {}).get("errors")]
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
