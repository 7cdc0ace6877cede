from __future__ import annotations

import re

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from chameleons.backend.auth import service
from chameleons.backend.auth.schemas import StaffUserCreate
from chameleons.backend.db import build_sessionmaker, session_scope


def add_user(engine: Engine, name: str, password: str, role: str) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        service.create_user(db, StaffUserCreate(username=name, password=password, role=role))


def csrf_from(html: str) -> str:
    match = re.search(r'name="csrf_token" value="([^"]+)"', html)
    assert match, "no CSRF token in the form"
    return match.group(1)


def login(client: TestClient, name: str, password: str) -> object:
    token = csrf_from(client.get("/login").text)
    return client.post(
        "/login",
        data={"username": name, "password": password, "csrf_token": token, "next": "/"},
        follow_redirects=False,
    )


def test_staff_page_redirects_to_login(client: TestClient) -> None:
    response = client.get("/", follow_redirects=False)
    assert response.status_code == 303
    assert response.headers["location"].startswith("/login?next=/")


def test_staff_api_needs_login(client: TestClient) -> None:
    response = client.get("/api/staff/me")
    assert response.status_code == 401


def test_login_logout_round_trip(client: TestClient, engine: Engine) -> None:
    add_user(engine, "pia", "correct horse", "pi")
    response = login(client, "pia", "correct horse")
    assert response.status_code == 303  # type: ignore[attr-defined]
    me = client.get("/api/staff/me").json()
    assert me["username"] == "pia"
    assert me["role"] == "pi"
    token = csrf_from(client.get("/").text)
    client.post("/logout", data={"csrf_token": token}, follow_redirects=False)
    assert client.get("/api/staff/me").status_code == 401


def test_wrong_password_is_rejected_with_a_message(client: TestClient, engine: Engine) -> None:
    add_user(engine, "wiz", "right password", "wizard")
    response = login(client, "wiz", "wrong password")
    assert response.status_code == 401  # type: ignore[attr-defined]
    assert "Wrong username or password." in response.text  # type: ignore[attr-defined]


def test_login_without_csrf_token_is_refused(client: TestClient, engine: Engine) -> None:
    add_user(engine, "wiz", "right password", "wizard")
    client.get("/login")
    response = client.post("/login", data={"username": "wiz", "password": "right password"})
    assert response.status_code == 403


def test_repeated_failures_lock_out(client: TestClient, engine: Engine) -> None:
    add_user(engine, "wiz", "right password", "wizard")
    for _ in range(3):  # login_max_failures=3 in the test settings
        login(client, "wiz", "nope nope")
    response = login(client, "wiz", "right password")
    assert response.status_code == 429  # type: ignore[attr-defined]
    assert "Too many failed attempts" in response.text  # type: ignore[attr-defined]


def test_pi_only_actions_refuse_wizards(client: TestClient, engine: Engine) -> None:
    add_user(engine, "wiz", "right password", "wizard")
    login(client, "wiz", "right password")
    token = csrf_from(client.get("/").text)
    response = client.post(
        "/api/staff/users",
        json={"username": "x2", "password": "long enough", "role": "wizard"},
        headers={"X-CSRF-Token": token},
    )
    assert response.status_code == 403


def test_pi_creates_user_but_needs_csrf(client: TestClient, engine: Engine) -> None:
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    body = {"username": "wiz2", "password": "long enough", "role": "wizard"}
    assert client.post("/api/staff/users", json=body).status_code == 403
    token = csrf_from(client.get("/").text)
    created = client.post("/api/staff/users", json=body, headers={"X-CSRF-Token": token})
    assert created.status_code == 201
    again = client.post("/api/staff/users", json=body, headers={"X-CSRF-Token": token})
    assert again.status_code == 409


@pytest.mark.parametrize("target", ["//evil.example/x", "https://evil.example/"])
def test_login_never_redirects_off_site(client: TestClient, engine: Engine, target: str) -> None:
    add_user(engine, "pia", "correct horse", "pi")
    token = csrf_from(client.get("/login").text)
    response = client.post(
        "/login",
        data={"username": "pia", "password": "correct horse", "csrf_token": token, "next": target},
        follow_redirects=False,
    )
    assert response.headers["location"] == "/"


def test_home_links_by_role(client: TestClient, engine: Engine) -> None:
    add_user(engine, "wiz", "right password", "wizard")
    login(client, "wiz", "right password")
    page = client.get("/").text
    assert 'href="/wizard"' in page
    assert 'href="/pi"' not in page


def test_a_wizard_on_a_pi_page_gets_a_readable_page(client: TestClient, engine: Engine) -> None:
    add_user(engine, "wiz", "right password", "wizard")
    login(client, "wiz", "right password")
    response = client.get("/pi")
    assert response.status_code == 403
    assert "This page is for the PI" in response.text
    assert client.get("/api/pi/overview").json()["detail"] == "Only the PI can do this."


def test_favicon(client: TestClient) -> None:
    response = client.get("/favicon.ico")
    assert response.status_code == 200
    assert response.text.startswith("<svg")
