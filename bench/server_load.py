"""The parts of ``bench.server_bench``: the servers in their own processes, console
sockets that time each update's arrival, phones in threads, figures."""

from __future__ import annotations

import json
import os
import secrets
import socket
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import httpx
from sqlalchemy import create_engine, text
from sqlalchemy.engine import make_url
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

ROOT = Path(__file__).resolve().parents[1]
START_SECONDS = 120.0
# uvicorn closes a connection after 5 s idle (``timeout_keep_alive``) and httpx keeps one
# for 5 s too: a request sent on it in the instant the server closes it is reset
# (ECONNRESET; one phone's walk in a 200-phone hold on PostgreSQL). A browser sends such a
# request again (Chromium's ``HttpNetworkTransaction::ShouldResendRequest``: a reused
# connection, no response headers yet); httpx does not, so the bench's phones let an idle
# connection go well before the server would.
CLIENT_KEEPALIVE_S = 2.0


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process so far (Linux ``/proc``): unlike latencies, a
    figure that a busy machine does not inflate."""
    with open(f"/proc/{pid}/stat") as handle:
        fields = handle.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def percentile(values: list[float], q: float) -> float:
    """The q-quantile by nearest rank (enough for p50/p99 of hundreds of samples)."""
    if not values:
        return float("nan")
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]


@dataclass
class Figures:
    http: list[float] = field(default_factory=list)
    update: list[float] = field(default_factory=list)  # submit -> its event message
    state: list[float] = field(default_factory=list)  # submit -> the console state after it
    errors: Counter[str] = field(default_factory=Counter)
    dropped: Counter[str] = field(default_factory=Counter)  # sockets closed under the bench
    server_cpu_s: float = 0.0  # the server process's CPU time over the scenario
    seconds: float = 0.0  # the scenario's wall time
    _lock: threading.Lock = field(default_factory=threading.Lock)

    def add(self, *, http: float | None, update: float | None, state: float | None = None) -> None:
        with self._lock:
            if http is not None:
                self.http.append(http)
            if update is not None:
                self.update.append(update)
            if state is not None:
                self.state.append(state)

    def count_error(self, what: str) -> None:
        with self._lock:
            self.errors[what] += 1

    def release(self, name: str, socket: Listener) -> None:
        """Close a socket the bench held, counting it as dropped if it was closed under it."""
        if socket.dropped:
            with self._lock:
                self.dropped[name] += 1
        socket.close()

    def summary(self) -> dict[str, Any]:
        with self._lock:
            ms = {f"{name}_{label}_ms": round(percentile(values, q) * 1000, 2)
                  for name, values in (("http", self.http), ("update", self.update),
                                       ("state", self.state))
                  for label, q in (("p50", 0.5), ("p99", 0.99))}  # fmt: skip
            submissions = len(self.http) + sum(self.errors.values())
            cpu_ms = 1000 * self.server_cpu_s / submissions if submissions else 0.0
            return {**ms, "submissions": submissions, "errors": dict(self.errors),
                    "dropped_sockets": dict(self.dropped), "seconds": round(self.seconds, 1),
                    "server_cpu_ms_per_submission": round(cpu_ms, 2)}  # fmt: skip


class Listener:
    """A WebSocket whose reader thread notes when each event key first arrives: the
    submission's client id, and ``kind:play_event_id`` for a prompt's speech events; and
    when the first console state after that event arrives (``wait_for_state``: what the
    wizard's console renders; the server sends a batch's events, then its state).

    Only event messages are parsed (the console's state messages can be large, and parsing
    them would put the load generator's CPU into the figures: a state is known by its first
    bytes). ``ended_codes`` are close
    codes that end the socket normally (the phone's 4410 when its session is over); any
    other close the bench did not ask for is a **dropped** socket."""

    clock = staticmethod(time.perf_counter)

    def __init__(self, url: str, origin: str, cookies: dict[str, str] | None = None,
                 *, ended_codes: tuple[int, ...] = ()) -> None:  # fmt: skip
        headers = {"Origin": origin}
        if cookies:
            headers["Cookie"] = "; ".join(f"{k}={v}" for k, v in cookies.items())
        self._connection = connect(url, additional_headers=headers, proxy=None,
                                   max_size=None, open_timeout=60)  # fmt: skip
        self._ended_codes = ended_codes
        self._seen: dict[str, float] = {}
        self._state_seen: dict[str, float] = {}
        self._awaiting_state: list[str] = []  # events seen, their state not yet
        self._condition = threading.Condition()
        self._closed = self._closing = False
        self.messages = 0
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    @staticmethod
    def pause(seconds: float) -> None:
        threading.Event().wait(seconds)

    def _read(self) -> None:
        try:
            for raw in self._connection:
                now = self.clock()
                self.messages += 1
                if _is_type(raw, "console"):
                    with self._condition:
                        for key in self._awaiting_state:
                            self._state_seen.setdefault(key, now)
                        self._awaiting_state.clear()
                        self._condition.notify_all()
                    continue
                if not _is_type(raw, "event"):
                    continue
                keys = _event_keys(json.loads(raw))
                if keys:
                    with self._condition:
                        for key in keys:
                            self._seen.setdefault(key, now)
                        self._awaiting_state.extend(keys)
                        self._condition.notify_all()
        except (ConnectionClosed, OSError, ValueError):
            pass
        finally:
            with self._condition:
                self._closed = True
                self._condition.notify_all()

    def wait_for(self, key: str, timeout: float) -> float | None:
        with self._condition:
            self._condition.wait_for(lambda: key in self._seen or self._closed, timeout)
            return self._seen.get(key)

    def wait_for_state(self, key: str, timeout: float) -> float | None:
        """When the first console state after the event ``key`` arrived."""
        with self._condition:
            self._condition.wait_for(lambda: key in self._state_seen or self._closed, timeout)
            return self._state_seen.get(key)

    @property
    def dropped(self) -> bool:
        """Closed by the other side (or the network) while the bench still held it."""
        if not self._closed or self._closing:
            return False
        return self._connection.close_code not in self._ended_codes

    def close(self) -> None:
        self._closing = not self._closed
        self._connection.close()
        self._thread.join(timeout=10)


Console = Listener  # the wizard console's socket; the phone's is a Listener too


def _is_type(raw: str | bytes, kind: str) -> bool:
    head = raw[:24] if isinstance(raw, str) else raw[:24].decode("utf-8", "replace")
    return head.replace(" ", "").startswith(f'{{"type":"{kind}"')


def _event_keys(message: Any) -> list[str]:
    """The keys of an event message: the real console nests the event
    (``{"type": "event", "event": {...}}``), the baseline sends it flat."""
    if not isinstance(message, dict) or message.get("type") != "event":
        return []
    event = message.get("event", message)
    if not isinstance(event, dict):
        return []
    keys = [event["client_id"]] if isinstance(event.get("client_id"), str) else []
    payload = event.get("payload")
    if isinstance(payload, dict) and payload.get("play_event_id") is not None:
        keys.append(f"{event.get('kind')}:{payload['play_event_id']}")
    return keys


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


def run_threads(jobs: Sequence[Callable[[], Any]], *, together: bool = False) -> None:
    """Each job in a thread of its own; with ``together`` they start at one barrier."""
    barrier = threading.Barrier(len(jobs)) if together else None
    failures: list[BaseException] = []

    def run(job: Callable[[], Any]) -> None:
        try:
            if barrier is not None:
                barrier.wait()
            job()
        except BaseException as error:  # reported after all threads ended
            failures.append(error)

    threads = [threading.Thread(target=run, args=(job,)) for job in jobs]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    if failures:
        raise RuntimeError(f"{len(failures)} phone(s) failed; the first: {failures[0]!r}")


@dataclass
class Server:
    """A server process on a loopback port of its own."""

    process: subprocess.Popen[bytes]
    base: str

    def client(self, cookies: dict[str, str] | None = None) -> httpx.Client:
        return httpx.Client(base_url=self.base, cookies=cookies, timeout=120.0,
                            limits=httpx.Limits(keepalive_expiry=CLIENT_KEEPALIVE_S))  # fmt: skip

    def ws_url(self, path: str) -> str:
        return "ws" + self.base.removeprefix("http") + path

    def wait_ready(self) -> None:
        deadline = time.monotonic() + START_SECONDS
        while True:
            if self.process.poll() is not None:
                raise RuntimeError(f"the server exited with {self.process.returncode}")
            try:
                if httpx.get(f"{self.base}/healthz", timeout=2).status_code == 200:
                    return
            except httpx.TransportError:
                pass
            if time.monotonic() > deadline:
                raise RuntimeError("the server did not answer /healthz")
            threading.Event().wait(0.1)

    def stop(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(30)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()

    @classmethod
    @contextmanager
    def _running(cls, command: list[str], env: dict[str, str], port: int) -> Iterator[Server]:
        process = subprocess.Popen(command, env=env, cwd=ROOT, stdin=subprocess.DEVNULL)
        server = cls(process, f"http://127.0.0.1:{port}")
        try:
            server.wait_ready()
            yield server
        finally:
            server.stop()

    @classmethod
    @contextmanager
    def baseline(cls, database_url: str | None = None) -> Iterator[Server]:
        """``bench.baseline_app``; with ``database_url`` it stores each submission there."""
        port = free_port()
        command = [sys.executable, "-m", "uvicorn", "bench.baseline_app:app", "--host",
                   "127.0.0.1", "--port", str(port), "--log-level", "warning"]  # fmt: skip
        env = {**os.environ, **({"BENCH_BASELINE_DATABASE_URL": database_url}
                                if database_url else {})}  # fmt: skip
        with cls._running(command, env, port) as server:
            yield server

    @classmethod
    @contextmanager
    def chameleons(
        cls, database_url: str, sessions: int, *, role: str = "wizard",
        env: dict[str, str] | None = None, phone_servers: int = 0,
    ) -> Iterator[tuple[Server, dict[str, Any]]]:  # fmt: skip
        """``chameleons serve`` on ``database_url`` (migrated, with studies whose plans have
        room for ``sessions`` and a staff member of ``role``), that staff member's cookie
        and CSRF, and the studies' ids. ``env`` adds settings (the worker link is off
        unless it says so). ``phone_servers``: as many more processes on the same database
        and secret (PostgreSQL: docs/deployment.md, "More than one server process"), in the set-up's
        ``phone_servers``, for the phones."""
        study_ids, username, password = _prepare(database_url, sessions, role)
        port = free_port()
        secret = secrets.token_urlsafe(32)
        with tempfile_dir() as data_dir:
            server_env = {**os.environ, "CHAMELEONS_DATABASE_URL": database_url,
                          "CHAMELEONS_DATA_DIR": str(data_dir),
                          "CHAMELEONS_SECRET_KEY": secret,
                          "CHAMELEONS_BRIDGE_ENABLED": "false",
                          "CHAMELEONS_LOG_LEVEL": "warning", **(env or {})}  # fmt: skip
            command = [sys.executable, "-m", "chameleons", "serve", "--host", "127.0.0.1",
                       "--port", str(port)]  # fmt: skip
            with cls._running(command, server_env, port) as server, ExitStack() as more:
                others = [more.enter_context(cls._running(
                    [*command[:-1], str(other)], server_env, other))
                    for other in (free_port() for _ in range(phone_servers))]  # fmt: skip
                login = _log_in(server, username, password)
                yield server, login | {"study_ids": study_ids, "secret_key": secret,
                                       "phone_servers": others}  # fmt: skip


def memory_mib(pid: int) -> dict[str, float]:
    """Resident memory of a process now and at its peak (``VmRSS``, ``VmHWM``), MiB."""
    found = {}
    with open(f"/proc/{pid}/status") as handle:
        for line in handle:
            name, _, value = line.partition(":")
            if name in ("VmRSS", "VmHWM"):
                found[name] = int(value.split()[0]) / 1024  # kB
    return {"rss_mib": round(found.get("VmRSS", 0.0), 1),
            "peak_rss_mib": round(found.get("VmHWM", 0.0), 1)}  # fmt: skip


@contextmanager
def tempfile_dir() -> Iterator[Path]:
    import tempfile

    with tempfile.TemporaryDirectory(prefix="chameleons-bench-data-") as tmp:
        yield Path(tmp)


def _prepare(database_url: str, sessions: int, role: str) -> tuple[list[int], str, str]:
    """Migrate, add a staff member (a fresh name: scenarios may share a database) and
    studies whose plans have room for ``sessions`` (a plan holds at most 1,000 rows)."""
    from chameleons.backend.auth import service as auth
    from chameleons.backend.auth.schemas import StaffUserCreate
    from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
    from chameleons.backend.migrate import upgrade
    from chameleons.backend.studies import service as studies
    from chameleons.experiment.study import load_default_study

    upgrade(database_url)
    tag = secrets.token_hex(4)
    username, password = f"bench-{tag}", secrets.token_urlsafe(16)
    count = -(-sessions // studies.MAX_PLAN_ROWS)
    engine = build_engine(database_url)
    try:
        with session_scope(build_sessionmaker(engine)) as db:
            auth.create_user(db, StaffUserCreate(username=username, password=password,
                                                 role=role))  # fmt: skip
            found = []
            for index in range(count):
                spec = replace(load_default_study(), name=f"Bench {tag}-{index}")
                study = studies.create_study(db, spec, plan_seed=1)
                studies.generate_plan(db, study, -(-sessions // count))
                found.append(study.id)
            return found, username, password
    finally:
        engine.dispose()


def _log_in(server: Server, username: str, password: str) -> dict[str, Any]:
    from chameleons.backend.sessions.bot import StaffApi

    with server.client() as http:
        staff = StaffApi(http).login(username, password)
        return {"cookies": dict(http.cookies.items()), "csrf": staff.csrf}


@contextmanager
def scratch_postgres(server_url: str) -> Iterator[str]:
    """A fresh database on the PostgreSQL server of ``server_url``, dropped afterwards."""
    url = make_url(server_url)
    if url.drivername == "postgresql":
        url = url.set(drivername="postgresql+psycopg")
    name = f"chameleons_bench_{secrets.token_hex(4)}"
    admin = create_engine(url, isolation_level="AUTOCOMMIT")
    try:
        with admin.connect() as conn:
            conn.execute(text(f'CREATE DATABASE "{name}"'))
        yield url.set(database=name).render_as_string(hide_password=False)
        with admin.connect() as conn:
            conn.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
    finally:
        admin.dispose()
