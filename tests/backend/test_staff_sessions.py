"""Staff logins live on the server: logout, "log out everywhere", deactivation and expiry
end them at once, even for a copied cookie; the PI manages accounts on /pi/staff and with
``chameleons user deactivate|activate|list``."""

from __future__ import annotations

import asyncio
import json
import logging
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from datetime import UTC, datetime, timedelta

import httpx
import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import Engine, select, update
from starlette.websockets import WebSocketDisconnect
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect
from websockets.sync.connection import Connection

from chameleons.backend.app import create_app
from chameleons.backend.auth.socket_revocation import StaffSockets
from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import StaffSession, StaffUser
from chameleons.settings import Settings
from tests.backend.test_auth import add_user, csrf_from, login
from tests.backend.test_cli import cli_env, run_cli
from tests.support.bots import PASSWORD, StaffApi, WizardBot, staff_api, study_with_plan
from tests.support.live_server import LiveServer

__all__ = ["cli_env"]
COOKIE = "chameleons_session"


def _client(app: FastAPI, cookie: str | None = None) -> TestClient:
    client = TestClient(app)
    if cookie is not None:
        client.cookies.set(COOKIE, cookie)
    return client


def _logged_in(app: FastAPI, name: str) -> TestClient:
    client = _client(app)
    assert login(client, name, f"{name} long password").status_code == 303  # type: ignore[attr-defined]
    return client


def _post(client: TestClient, path: str, page: str = "/") -> int:
    token = csrf_from(client.get(page).text)
    return client.post(path, data={"csrf_token": token}, follow_redirects=False).status_code


def _me(client: TestClient) -> int:
    return client.get("/api/staff/me").status_code


@pytest.fixture
def accounts(engine: Engine) -> None:
    add_user(engine, "pia", "pia long password", "pi")
    add_user(engine, "wiz", "wiz long password", "wizard")


@pytest.mark.usefixtures("accounts")
def test_a_cookie_replayed_after_logout_is_refused(app: FastAPI) -> None:
    client = _logged_in(app, "wiz")
    copied = client.cookies[COOKIE]
    assert _me(client) == 200
    assert _post(client, "/logout") == 303
    replay = _client(app, copied)
    assert _me(replay) == 401
    assert replay.get("/wizard", follow_redirects=False).status_code == 303  # to /login
    with (
        pytest.raises(WebSocketDisconnect) as refused,
        replay.websocket_connect("/ws/wizard/sessions/1") as socket,
    ):
        socket.receive_text()
    assert refused.value.code == 4401


@pytest.mark.usefixtures("accounts")
def test_log_out_everywhere_ends_every_session_of_the_account(app: FastAPI) -> None:
    laptop, tablet = _logged_in(app, "wiz"), _logged_in(app, "wiz")
    other = _logged_in(app, "pia")
    assert _post(laptop, "/logout/everywhere") == 303
    assert (_me(laptop), _me(tablet), _me(other)) == (401, 401, 200)
    assert _me(_logged_in(app, "wiz")) == 200  # the account itself still works


@pytest.mark.usefixtures("accounts")
def test_the_pi_deactivates_an_account_and_its_sessions_end_at_once(
    app: FastAPI, engine: Engine
) -> None:
    wizard, pi = _logged_in(app, "wiz"), _logged_in(app, "pia")
    with session_scope(build_sessionmaker(engine)) as db:
        wiz_id = db.scalars(select(StaffUser.id).where(StaffUser.username == "wiz")).one()
        pi_id = db.scalars(select(StaffUser.id).where(StaffUser.username == "pia")).one()
    page = pi.get("/pi/staff")
    assert page.status_code == 200
    assert 'data-account="wiz"' in page.text
    assert _post(pi, f"/pi/staff/{wiz_id}/deactivate", "/pi/staff") == 303
    assert _me(wizard) == 401
    assert login(_client(app), "wiz", "wiz long password").status_code == 401  # type: ignore[attr-defined]
    assert _post(pi, f"/pi/staff/{pi_id}/deactivate", "/pi/staff") == 400  # not oneself
    assert _post(pi, f"/pi/staff/{wiz_id}/activate", "/pi/staff") == 303
    assert _me(wizard) == 401  # the old session stays ended
    assert _me(_logged_in(app, "wiz")) == 200
    assert _post(_logged_in(app, "wiz"), f"/pi/staff/{wiz_id}/deactivate", "/") == 403


@pytest.mark.usefixtures("accounts")
def test_an_expired_session_is_refused(app: FastAPI, engine: Engine) -> None:
    client = _logged_in(app, "wiz")
    assert _me(client) == 200
    with session_scope(build_sessionmaker(engine)) as db:
        db.execute(update(StaffSession).values(expires_at=datetime.now(UTC) - timedelta(1)))
    assert _me(client) == 401


@pytest.mark.usefixtures("accounts")
def test_the_pi_adds_an_account_and_a_bad_one_is_explained(app: FastAPI) -> None:
    pi = _logged_in(app, "pia")
    token = csrf_from(pi.get("/pi/staff").text)
    bad = pi.post("/pi/staff", data={"csrf_token": token, "username": "new", "password": "x"})
    assert bad.status_code == 400
    assert 'role="alert"' in bad.text
    good = pi.post(
        "/pi/staff",
        data={"csrf_token": token, "username": "newwiz", "password": "a long password!"},
    )
    assert good.status_code == 200
    assert 'data-account="newwiz"' in good.text


def test_the_cookie_lives_as_long_as_the_setting_and_is_secure_behind_https(
    settings: Settings,
) -> None:
    assert settings.cookie_secure is False  # plain http (tests, the demo)
    https = settings.model_copy(
        update={"public_url": "https://lab.example", "staff_session_hours": 2.0}
    )
    assert https.cookie_secure is True
    assert https.model_copy(update={"session_cookie_secure": False}).cookie_secure is False
    app = create_app(https)
    try:
        with TestClient(app, base_url="https://testserver") as client:
            response = client.get("/login")
        cookie = response.headers["set-cookie"].lower()
        assert "secure" in cookie
        assert "max-age=7200" in cookie
    finally:
        app.state.engine.dispose()


def test_user_deactivate_activate_and_list_on_the_command_line(cli_env: dict[str, str]) -> None:
    assert run_cli("db", "upgrade", env=cli_env).returncode == 0
    run_cli("user", "add", "wiz", "--role", "wizard", "--password", "pw-123456", env=cli_env)
    listed = run_cli("user", "list", env=cli_env)
    assert "wiz\twizard\tactive\t0 open session(s)" in listed.stdout, listed.stderr
    off = run_cli("user", "deactivate", "wiz", env=cli_env)
    assert off.returncode == 0, off.stderr
    assert "wiz\twizard\tdeactivated" in run_cli("user", "list", env=cli_env).stdout
    assert run_cli("user", "activate", "wiz", env=cli_env).returncode == 0
    missing = run_cli("user", "deactivate", "nobody", env=cli_env)
    assert missing.returncode != 0
    assert "no staff account 'nobody'" in missing.stderr


# --- WebSockets already open when the login ends ---------------------------------------
# Through a real uvicorn server: the console's, the live feed's and a staff-opened robot
# display's sockets close with 4401 (and a logged reason) when their login ends, while
# other staff members' sockets carry on.

WAIT_S = 120.0  # generous: only a socket that is never closed comes near it
GUARD_LOG = "chameleons.backend.events.guard"


@pytest.fixture
def browsers(served: LiveServer) -> Iterator[Callable[[], httpx.Client]]:
    """New HTTP clients to the live server, each with its own cookies, closed afterwards."""
    with ExitStack() as stack:
        yield lambda: stack.enter_context(httpx.Client(base_url=served.url, timeout=WAIT_S))


@pytest.fixture
def served(app: FastAPI) -> Iterator[LiveServer]:
    with LiveServer(app) as live:
        yield live


def _socket(server: LiveServer, path: str, staff: StaffApi) -> ClientConnection:
    cookies = "; ".join(f"{k}={v}" for k, v in staff.http.cookies.items())
    return connect(
        f"ws://127.0.0.1:{server.port}{path}",
        additional_headers={"Origin": server.url, "Cookie": cookies},
        open_timeout=WAIT_S,
    )


def _close_of(socket: Connection) -> tuple[int | None, str | None]:
    """Read until the server closes the socket; its close code and reason."""
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        try:
            socket.recv(timeout=WAIT_S)
        except ConnectionClosed:
            return socket.close_code, socket.close_reason
    raise AssertionError("the socket stayed open")


def _answers_a_ping(socket: Connection) -> bool:
    socket.send(json.dumps({"type": "ping"}))
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        if json.loads(socket.recv(timeout=WAIT_S)).get("type") == "pong":
            return True
    return False


def _submit(staff: StaffApi, path: str) -> int:
    headers = {"X-CSRF-Token": staff.csrf}
    return staff.http.post(path, headers=headers, follow_redirects=False).status_code


def _closed_in_log(caplog: pytest.LogCaptureFixture, reason: str) -> int:
    wanted = f"closed (4401): staff session ended ({reason})"
    return sum(wanted in record.getMessage() for record in caplog.records)


@pytest.mark.parametrize("kind", ["console", "feed", "display"])
def test_an_open_staff_socket_is_closed_at_logout(
    engine: Engine,
    served: LiveServer,
    browsers: Callable[[], httpx.Client],
    caplog: pytest.LogCaptureFixture,
    kind: str,
) -> None:
    pi = staff_api(browsers(), engine, "pi")
    wizard = staff_api(browsers(), engine, "wizard")
    session_id = WizardBot.create(pi, study_with_plan(pi)).session_id
    path = {
        "console": f"/ws/wizard/sessions/{session_id}",
        "feed": f"/ws/sessions/{session_id}",
        "display": "/ws/display/booth-1",  # opened with the staff cookie, not a link
    }[kind]
    with (
        caplog.at_level(logging.WARNING, logger=GUARD_LOG),
        _socket(served, path, wizard) as wizards,
        _socket(served, f"/ws/wizard/sessions/{session_id}", pi) as pis,
    ):
        wizards.recv(timeout=WAIT_S)  # open and served
        assert _submit(wizard, "/logout") == 303
        assert _close_of(wizards) == (4401, "staff session ended (logout)")
        assert _answers_a_ping(pis)  # the PI's login, and socket, carry on
    assert _closed_in_log(caplog, "logout") == 1


@pytest.mark.parametrize(
    ("who", "action", "reason"),
    [
        ("pi", "/pi/staff/{id}/deactivate", "deactivated"),
        ("pi", "/pi/staff/{id}/logout", "ended by the PI"),
        ("wizard", "/logout/everywhere", "logged out everywhere"),
    ],
)
def test_deactivation_and_log_out_everywhere_close_every_socket_of_the_account(
    engine: Engine,
    served: LiveServer,
    browsers: Callable[[], httpx.Client],
    caplog: pytest.LogCaptureFixture,
    who: str,
    action: str,
    reason: str,
) -> None:
    pi = staff_api(browsers(), engine, "pi")
    laptop = staff_api(browsers(), engine, "wizard", "wiz")
    tablet = StaffApi(browsers()).login("wiz", PASSWORD)
    session_id = WizardBot.create(pi, study_with_plan(pi)).session_id
    console = f"/ws/wizard/sessions/{session_id}"
    with session_scope(build_sessionmaker(engine)) as db:
        wiz_id = db.scalars(select(StaffUser.id).where(StaffUser.username == "wiz")).one()
    with (
        caplog.at_level(logging.WARNING, logger=GUARD_LOG),
        _socket(served, console, laptop) as on_laptop,
        _socket(served, f"/ws/sessions/{session_id}", tablet) as on_tablet,
        _socket(served, console, pi) as pis,
    ):
        on_laptop.recv(timeout=WAIT_S)
        on_tablet.recv(timeout=WAIT_S)
        actor = pi if who == "pi" else tablet
        assert _submit(actor, action.format(id=wiz_id)) == 303
        assert _close_of(on_laptop) == (4401, f"staff session ended ({reason})")
        assert _close_of(on_tablet) == (4401, f"staff session ended ({reason})")
        assert _answers_a_ping(pis)
    assert _closed_in_log(caplog, reason) == 2


@pytest.fixture
def app_rechecking(settings: Settings, engine: Engine) -> Iterator[FastAPI]:
    """On SQLite the server re-checks its staff sockets often (nothing else tells it of a
    command's deactivation); on PostgreSQL hardly ever, so the command's NOTIFY must do."""
    every = 0.2 if engine.dialect.name == "sqlite" else 3600.0
    app = create_app(settings.model_copy(update={"staff_socket_recheck_s": every}))
    yield app
    app.state.engine.dispose()


def test_a_deactivation_on_the_command_line_closes_the_accounts_sockets(
    app_rechecking: FastAPI,
    engine: Engine,
    database_url: str,
    cli_env: dict[str, str],
) -> None:
    with LiveServer(app_rechecking) as server, httpx.Client(base_url=server.url) as http:
        wizard = staff_api(http, engine, "wizard", "wiz")
        with _socket(server, "/ws/display/booth-1", wizard) as display:
            display.recv(timeout=WAIT_S)
            off = run_cli("user", "deactivate", "wiz", env=_with_db(cli_env, database_url))
            assert off.returncode == 0, off.stderr
            assert _close_of(display) == (4401, "staff session ended (deactivated)")


def test_an_expired_login_closes_its_open_sockets(app_rechecking: FastAPI, engine: Engine) -> None:
    if engine.dialect.name != "sqlite":
        pytest.skip("the re-check is the same on both databases; SQLite re-checks often here")
    with LiveServer(app_rechecking) as server, httpx.Client(base_url=server.url) as http:
        wizard = staff_api(http, engine, "wizard", "wiz")
        with _socket(server, "/ws/display/booth-1", wizard) as display:
            display.recv(timeout=WAIT_S)
            with session_scope(build_sessionmaker(engine)) as db:
                past = datetime.now(UTC) - timedelta(seconds=1)
                db.execute(update(StaffSession).values(expires_at=past))
            assert _close_of(display) == (4401, "staff session ended (expired)")


def _with_db(env: dict[str, str], database_url: str) -> dict[str, str]:
    return {**env, "CHAMELEONS_DATABASE_URL": database_url}


def test_a_notice_that_comes_before_its_socket_registers_still_closes_it() -> None:
    """The handshake checked the login, then the session ended, then the socket registered:
    the notice is remembered (ended sessions never reopen), for a while only."""
    registry = StaffSockets()

    async def scenario() -> tuple[bool, bool]:
        registry.end([7], "logout")
        with registry.watch(7) as late, registry.watch(8) as other:
            return late.ended.is_set(), other.ended.is_set()

    assert asyncio.run(scenario()) == (True, False)
    assert registry.remembered() == 1
