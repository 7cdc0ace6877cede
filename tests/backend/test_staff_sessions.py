"""Staff logins live on the server: logout, "log out everywhere", deactivation and expiry
end them at once, even for a copied cookie; the PI manages accounts on /pi/staff and with
``chameleons user deactivate|activate|list``."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import Engine, select, update
from starlette.websockets import WebSocketDisconnect

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import StaffSession, StaffUser
from chameleons.settings import Settings
from tests.backend.test_auth import add_user, csrf_from, login
from tests.backend.test_cli import cli_env, run_cli

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
    from chameleons.backend.app import create_app

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
