"""Two server processes on one PostgreSQL database: a phone answering on one updates a
console watching on the other (events.pg_fanout, LISTEN/NOTIFY).

Most tests here run the two servers as two apps, each with its own uvicorn server, event
loop, thread pool and live hub, in threads of this process (nothing connects their hubs but
PostgreSQL, and the apps' state can be looked into); one runs two real ``chameleons serve``
processes, as a deployment does (the topology: README "More than one server process" and
docs/performance.md)."""

from __future__ import annotations

import json
import os
import random
import secrets
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import pytest
from fastapi import FastAPI
from sqlalchemy import Engine, text
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect
from websockets.sync.connection import Connection

from chameleons.backend.app import create_app
from chameleons.backend.events import jsontext
from chameleons.backend.events.hub import RESYNC, session_channel
from chameleons.backend.events.pg_fanout import MAX_PAYLOAD, encode
from chameleons.backend.phone import devices
from chameleons.backend.phone.retained import PHONE_VIEW, committed
from chameleons.backend.phone.view import phone_state
from chameleons.backend.sessions.flow import load_by_token
from chameleons.backend.sessions.snapshot import CONSOLE_VIEW, phone_presence_key
from chameleons.settings import Settings
from tests.backend.wizard.test_retained_state import newest_event, read_console, statements_here
from tests.support.bots import (
    HttpClient,
    ParticipantBot,
    WizardBot,
    drive_session,
    staff_api,
    study_with_plan,
)
from tests.support.live_server import LiveServer

WAIT_S = 120.0
DEVICE = "0123456789abcdef"  # the phone page's own id for itself


def wait_until(condition: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + WAIT_S
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting until {what}")
        time.sleep(0.01)


Served = tuple[LiveServer, FastAPI]


@pytest.fixture
def two_servers(settings: Settings, engine: Engine) -> Iterator[tuple[Served, Served]]:
    if engine.dialect.name != "postgresql":
        pytest.skip("one SQLite server is one process: the fan-out is PostgreSQL's")
    # Staff sockets are not re-checked meanwhile: a logout on one server must reach the
    # other's sockets through the fan-out itself.
    settings = settings.model_copy(update={"staff_socket_recheck_s": 3600.0})
    apps = [create_app(settings), create_app(settings)]
    with LiveServer(apps[0]) as first, LiveServer(apps[1]) as second:
        for app in apps:
            wait_until(lambda app=app: _listening(app), "both servers listen")  # type: ignore[misc]
        yield (first, apps[0]), (second, apps[1])
    for app in apps:
        app.state.engine.dispose()


def _listening(app: FastAPI) -> bool:
    fanout = app.state.live_fanout
    return fanout is not None and fanout.listening.is_set()


def _console(
    server: LiveServer | ServeProcess, session_id: int, http: httpx.Client
) -> ClientConnection:
    cookies = "; ".join(f"{k}={v}" for k, v in http.cookies.items())
    return connect(
        f"ws://127.0.0.1:{server.port}/ws/sessions/{session_id}",
        additional_headers={"Origin": server.url, "Cookie": cookies},
        open_timeout=WAIT_S,
    )


@contextmanager
def _wizard_and_phone(
    console_url: str, phone_url: str, engine: Engine
) -> Iterator[tuple[httpx.Client, httpx.Client, WizardBot]]:
    """Staff HTTP on the console's server, the phone's on the other, and a new session's
    wizard (a PI's study with a plan)."""
    with (
        httpx.Client(base_url=console_url, timeout=WAIT_S) as staff_http,
        httpx.Client(base_url=phone_url, timeout=WAIT_S) as phone_http,
    ):
        pi = staff_api(staff_http, engine, "pi")
        yield staff_http, phone_http, WizardBot.create(pi, study_with_plan(pi))


def _next_matching(socket: Connection, match: Callable[[Any], bool]) -> Any:
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        message = json.loads(socket.recv(timeout=max(0.1, deadline - time.monotonic())))
        if match(message):
            return message
    raise AssertionError("no matching message")


def _consent_seen_by(
    console: Connection, phone_http: httpx.Client, token: str, client_id: str
) -> Any:
    """The phone agrees (on its server) once the console has its first state; the event the
    console then receives for that answer."""
    _next_matching(console, lambda m: m.get("type") == "snapshot")
    ParticipantBot(phone_http, token).consent(True, client_id=client_id)
    return _next_matching(
        console,
        lambda m: m.get("type") == "event" and m["event"].get("client_id") == client_id,
    )


def test_a_phone_on_one_server_updates_a_console_on_the_other(
    two_servers: tuple[Served, Served], engine: Engine
) -> None:
    (phone_server, phone_app), (console_server, console_app) = two_servers
    with _wizard_and_phone(console_server.url, phone_server.url, engine) as (
        staff_http,
        phone_http,
        wizard,
    ):
        with _console(console_server, wizard.session_id, staff_http) as console:
            event = _consent_seen_by(console, phone_http, wizard.token, "fanout-consent")
            assert event["event"]["session_id"] == wizard.session_id
            snapshot = _next_matching(console, lambda m: m.get("type") == "snapshot")
            assert snapshot["session"]["id"] == wizard.session_id

        key = phone_presence_key(wizard.session_id)
        assert console_app.state.live_hub.present(key) == 0
        with connect(
            f"ws://127.0.0.1:{phone_server.port}/ws/p/{wizard.token}?device={DEVICE}",
            open_timeout=WAIT_S,
        ):
            wait_until(lambda: phone_app.state.live_hub.present(key) == 1, "the phone is in")
            wait_until(
                lambda: console_app.state.live_hub.present(key) == 1,
                "the other server counts the phone",
            )
            # ... and knows which phone it is (the console lists two phones on one link).
            listed = devices.phones(console_app.state.live_hub, wizard.session_id)
            assert [phone["id"] for phone in listed] == [DEVICE]
        wait_until(
            lambda: console_app.state.live_hub.present(key) == 0,
            "the other server sees the phone leave",
        )


def _kept_version(app: FastAPI, session_id: int, view: str) -> int | None:
    found = app.state.live_hub.retained(session_channel(session_id), view)
    return None if found is None else int(found["version"])


@dataclass
class PhoneOnOtherServer(ParticipantBot):
    """A phone on one server, its wizard and console on the other. Before each submission
    the phone's server keeps the phone view the wizard's last action committed; after it,
    the console's server keeps the state the answer committed (both came through NOTIFY).
    Each is taken without a statement and equals a fresh read."""

    apps: tuple[FastAPI, FastAPI] | None = None  # (the phone's, the console's)
    session_id: int = 0
    checked: int = 0

    def _send(self, kind: str, body: dict[str, Any]) -> dict[str, Any]:
        self._check_phone_view()
        receipt = super()._send(kind, body)
        self._check_console_state()
        self.checked += 1
        return receipt

    def _apps(self) -> tuple[FastAPI, FastAPI]:
        assert self.apps is not None
        return self.apps

    def _check_phone_view(self) -> None:
        phone_app, console_app = self._apps()
        newest = newest_event(console_app, self.session_id)["id"]
        wait_until(lambda: _kept_version(phone_app, self.session_id, PHONE_VIEW) == newest,
                   "the phone's server keeps the view the wizard's action made")  # fmt: skip
        batch = [{"type": "event", "event": {"id": newest}}]
        with statements_here() as statements:
            kept = committed(phone_app.state.live_hub, self.session_id, batch)
        assert statements == []
        with phone_app.state.sessionmaker() as db:
            fresh = phone_state(load_by_token(db, self.token, lock=False))
        assert json.loads(jsontext.dumps(kept)) == json.loads(jsontext.dumps(fresh))

    def _check_console_state(self) -> None:
        _, console_app = self._apps()
        newest = newest_event(console_app, self.session_id)
        wait_until(lambda: _kept_version(console_app, self.session_id, CONSOLE_VIEW)
                   == newest["id"], "the console's server keeps the answer's state")  # fmt: skip
        with statements_here() as statements:
            kept = read_console(console_app, self.session_id, [newest])
        assert statements == []
        assert kept["session"] == read_console(console_app, self.session_id, None)["session"]


def test_the_views_a_change_made_reach_the_other_server_with_its_events(
    two_servers: tuple[Served, Served], engine: Engine
) -> None:
    """A whole session, the phone on one server and the wizard on the other: neither server
    loads the session again for the other's changes (docs/performance.md)."""
    (phone_server, phone_app), (console_server, console_app) = two_servers
    with _wizard_and_phone(console_server.url, phone_server.url, engine) as (
        _staff_http,
        phone_http,
        wizard,
    ):
        http: HttpClient = phone_http
        phone = PhoneOnOtherServer(http, wizard.token, apps=(phone_app, console_app),
                                   session_id=wizard.session_id)  # fmt: skip
        result = drive_session(wizard, phone, random.Random(5))
    assert result.snapshot["state"] == "complete"
    assert phone.checked == len(phone.sent) >= 2 * len(result.snapshot["interactions"])


def test_a_message_too_large_for_notify_becomes_a_resync() -> None:
    small = json.loads(encode("me", "session:1", {"type": "event", "n": 1}))
    assert small == {"o": "me", "c": "session:1", "m": {"type": "event", "n": 1}}
    large = json.loads(encode("me", "session:1", {"type": "event", "text": "x" * MAX_PAYLOAD}))
    assert large == {"o": "me", "c": "session:1", "m": RESYNC}


def test_a_server_whose_database_connections_drop_reconnects_and_carries_on(
    two_servers: tuple[Served, Served], engine: Engine
) -> None:
    """PostgreSQL ends the connection the phone server sends its notifications on (an
    idle-connection timeout, a network cut) while its listening connection stays up: the
    failed send ends both, the server reconnects, and the next answer on it still reaches
    the other console (a silently dead sender would drop every later message)."""
    (phone_server, phone_app), (console_server, _console_app) = two_servers
    fanout = phone_app.state.live_fanout
    before = fanout.backend_pids
    with engine.connect() as connection:
        connection.execute(text("SELECT pg_terminate_backend(:pid)"), {"pid": before[1]})
    # The next message (a heartbeat within HEARTBEAT_S, or any event) finds the dead
    # connection; until then nothing was lost.
    wait_until(
        lambda: fanout.listening.is_set() and fanout.backend_pids[0] not in before,
        "the phone server listens again on new connections",
    )
    assert fanout.backend_pids[1] not in before
    with (
        _wizard_and_phone(console_server.url, phone_server.url, engine) as (
            staff_http,
            phone_http,
            wizard,
        ),
        _console(console_server, wizard.session_id, staff_http) as console,
    ):
        _consent_seen_by(console, phone_http, wizard.token, "after-reconnect")


def test_a_logout_on_one_server_closes_the_staff_sockets_on_the_other(
    two_servers: tuple[Served, Served], engine: Engine
) -> None:
    (first, _), (second, _) = two_servers
    with (
        httpx.Client(base_url=first.url, timeout=WAIT_S) as on_first,
        httpx.Client(base_url=second.url, timeout=WAIT_S) as on_second,
    ):
        pi = staff_api(on_first, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi))
        # The same login (its cookie) on the second server: a console open there.
        on_second.cookies.update(on_first.cookies)
        with _console(second, wizard.session_id, on_second) as console:
            _next_matching(console, lambda m: m.get("type") == "snapshot")
            logout = on_first.post("/logout", headers={"X-CSRF-Token": pi.csrf})
            assert logout.status_code == 303
            with pytest.raises(ConnectionClosed):
                _next_matching(console, lambda _m: False)
            assert (console.close_code, console.close_reason) == (
                4401,
                "staff session ended (logout)",
            )


@dataclass
class ServeProcess:
    """A ``chameleons serve`` OS process on a free loopback port."""

    process: subprocess.Popen[bytes]
    port: int

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def ready(self) -> bool:
        if self.process.poll() is not None:
            raise AssertionError(f"chameleons serve exited with {self.process.returncode}")
        try:
            return httpx.get(f"{self.url}/healthz", timeout=5).status_code == 200
        except httpx.TransportError:
            return False


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@contextmanager
def serve_process(
    database_url: str, secret: str, data_dir: Path, extra_env: dict[str, str] | None = None
) -> Iterator[ServeProcess]:
    """Started; stopped (SIGTERM, then SIGKILL) at the end. No worker link: the processes
    would both bind its ports (in a deployment, one process runs it)."""
    port = _free_port()
    env = {**os.environ, "CHAMELEONS_DATABASE_URL": database_url,
           "CHAMELEONS_SECRET_KEY": secret, "CHAMELEONS_DATA_DIR": str(data_dir),
           "CHAMELEONS_BRIDGE_ENABLED": "false", "CHAMELEONS_LOG_LEVEL": "warning",
           **(extra_env or {})}  # fmt: skip
    command = [sys.executable, "-m", "chameleons", "serve", "--host", "127.0.0.1",
               "--port", str(port)]  # fmt: skip
    process = subprocess.Popen(command, env=env, stdin=subprocess.DEVNULL)
    try:
        yield ServeProcess(process, port)
    finally:
        process.terminate()
        try:
            process.wait(30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def _listening_connections(engine: Engine) -> int:
    """Connections to this database that listen for the fan-out's notifications (each
    server process keeps one, idle after its LISTEN)."""
    with engine.connect() as connection:
        return int(connection.execute(text(
            "SELECT count(*) FROM pg_stat_activity WHERE datname = current_database() "
            "AND query ILIKE 'LISTEN %'"
        )).scalar_one())  # fmt: skip


def test_two_serve_processes_carry_a_phone_answer_to_the_other_ones_console(
    database_url: str, engine: Engine, tmp_path: Path
) -> None:
    if engine.dialect.name != "postgresql":
        pytest.skip("one SQLite server is one process: the fan-out is PostgreSQL's")
    secret = secrets.token_urlsafe(32)  # shared, as the deployment's .env is
    with (
        serve_process(database_url, secret, tmp_path / "a") as phone_server,
        serve_process(database_url, secret, tmp_path / "b") as console_server,
    ):
        wait_until(lambda: phone_server.ready() and console_server.ready(), "both answer")
        wait_until(lambda: _listening_connections(engine) >= 2, "both processes listen")
        with (
            _wizard_and_phone(console_server.url, phone_server.url, engine) as (
                staff_http,
                phone_http,
                wizard,
            ),
            _console(console_server, wizard.session_id, staff_http) as console,
        ):
            event = _consent_seen_by(console, phone_http, wizard.token, "between-processes")
            assert event["event"]["session_id"] == wizard.session_id
            assert event["event"]["kind"] == "consent.given"
