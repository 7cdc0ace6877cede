"""Security headers on every HTTP response: pages, API, static files, redirects, errors and
token pages; the API documentation keeps its own nonce-based policy; WebSockets still work
through the middleware."""

from __future__ import annotations

import re

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.security_headers import CONTENT_SECURITY_POLICY
from tests.support.bots import PASSWORD, add_staff


def _assert_headers(response: object, policy: str = CONTENT_SECURITY_POLICY) -> None:
    headers = response.headers  # type: ignore[attr-defined]
    assert headers["content-security-policy"] == policy
    assert headers["x-frame-options"] == "DENY"
    assert headers["x-content-type-options"] == "nosniff"
    assert headers["referrer-policy"] in ("same-origin", "no-referrer")


def test_the_policy_forbids_inline_script_and_framing() -> None:
    directives = dict(d.split(" ", 1) for d in CONTENT_SECURITY_POLICY.split("; "))
    assert directives["script-src"] == "'self'"
    assert "unsafe" not in CONTENT_SECURITY_POLICY
    assert directives["frame-ancestors"] == "'none'"
    assert directives["object-src"] == "'none'"


@pytest.mark.parametrize(
    ("path", "status"),
    [
        ("/login", 200),
        ("/healthz", 200),
        ("/static/css/app.css", 200),
        ("/static/wizard/console.js", 200),
        ("/static/no-such-file.js", 404),
        ("/favicon.ico", 200),
        ("/openapi.json", 200),
        ("/pi", 303),  # a redirect to the login
        ("/api/pi/overview", 401),
        ("/p/not-a-token", 404),
        ("/no/such/page", 404),
    ],
)
def test_every_kind_of_response_carries_the_headers(
    client: TestClient, path: str, status: int
) -> None:
    response = client.get(path, follow_redirects=False)
    assert response.status_code == status, response.text
    _assert_headers(response)


def test_logged_in_pages_and_api_carry_the_headers(client: TestClient, engine: object) -> None:
    add_staff(engine, "pia", "pi")  # type: ignore[arg-type]
    page = client.get("/login")
    csrf = re.search(r'name="csrf_token" value="([^"]+)"', page.text)
    assert csrf

    client.post(
        "/login", data={"username": "pia", "password": PASSWORD, "csrf_token": csrf.group(1)}
    )
    for path in ("/", "/pi/staff", "/wizard", "/studies", "/api/studies"):
        response = client.get(path, follow_redirects=False)
        assert response.status_code == 200, path
        _assert_headers(response)


STAFF_PATHS = ["/", "/pi", "/pi/staff", "/wizard", "/studies", "/api/studies",
               "/api/staff/me", "/pi/sessions/999999", "/pi/no-such-page"]  # fmt: skip


def test_staff_pages_api_and_errors_are_never_stored_but_assets_are_cacheable(
    client: TestClient, engine: object
) -> None:
    """A staff page kept in the browser's cache (or its back/forward history) shows the
    study's data to the next person at a shared lab PC after the PI logged out."""
    add_staff(engine, "pia", "pi")  # type: ignore[arg-type]
    before = client.get("/login")
    assert before.headers["cache-control"] == "no-store"
    assert client.get("/pi", follow_redirects=False).headers["cache-control"] == "no-store"
    csrf = re.search(r'name="csrf_token" value="([^"]+)"', before.text)
    assert csrf
    data = {"username": "pia", "password": PASSWORD, "csrf_token": csrf.group(1)}
    assert client.post("/login", data=data, follow_redirects=False).status_code == 303
    for path in STAFF_PATHS:
        response = client.get(path, follow_redirects=False)
        assert response.headers.get("cache-control") == "no-store", (path, response.status_code)
    for path in ("/static/css/app.css", "/favicon.ico"):
        response = client.get(path)
        assert response.status_code == 200
        assert "no-store" not in response.headers.get("cache-control", ""), path


def test_participant_pages_keep_no_referrer(client: TestClient) -> None:
    # The phone's own stricter value wins over the app-wide same-origin.
    response = client.get("/p/not-a-token")
    assert response.headers["referrer-policy"] == "no-referrer"


def test_api_docs_run_only_their_nonced_scripts(client: TestClient) -> None:
    response = client.get("/docs")
    assert response.status_code == 200
    policy = response.headers["content-security-policy"]
    nonce = re.search(r"script-src 'nonce-([\w-]+)'", policy)
    assert nonce, policy
    scripts = re.findall(r"<script[^>]*>", response.text)
    assert scripts
    assert all(f'nonce="{nonce.group(1)}"' in s for s in scripts)
    assert "frame-ancestors 'none'" in policy
    assert response.headers["x-frame-options"] == "DENY"
    assert client.get("/docs").headers["content-security-policy"] != policy  # fresh nonce
    assert client.get("/redoc").status_code == 404


def test_an_unexpected_error_is_a_bare_500_with_the_headers(app: FastAPI) -> None:
    """Starlette answers unhandled exceptions outside every middleware: the app's own
    handler gives that answer the headers, and no traceback reaches the client."""

    def broken() -> None:
        raise RuntimeError("a bug with a secret detail")

    app.add_api_route("/test-broken", broken)
    with TestClient(app, raise_server_exceptions=False) as client:
        response = client.get("/test-broken")
    assert response.status_code == 500
    assert response.text == "Internal Server Error"
    _assert_headers(response)
