"""Every HTTP route of the app, enumerated from its OpenAPI schema: staff routes refuse
anonymous callers, PI routes refuse wizards, and the participant/display routes refuse
wrong tokens. A new route fails here until it is protected or listed as public."""

from __future__ import annotations

import re

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from tests.backend.test_auth import add_user, csrf_from, login

# Public by design (no login): health, login, and the token-guarded participant and display
# routes, which are called here with a wrong token.
# A lab's robot head files are public like the static files: the display page loads them.
PUBLIC = {"/healthz", "/login", "/join", "/favicon.ico", "/display-heads/{name}"}
TOKEN_GUARDED = re.compile(
    r"^/(p/|api/phone/|display/\{booth\}/\{token\}|capture/\{booth\}/\{token\}|media/"
    r"|video/\{booth\}/\{token\}|api/video/)"
)
PI_ONLY = re.compile(r"^/(pi\b|api/pi/|api/staff/users)")
# Wizards may read the study and its plan; changing them is the PI's.
PI_ONLY_POSTS = {
    "/api/studies", "/api/studies/{study_id}/plan", "/studies", "/studies/{study_id}/plan",
}  # fmt: skip
VALUES = {
    "study_id": "1", "session_id": "1", "token": "not-a-token", "code": "P001",
    "measure": "trust", "fmt": "svg", "recording_id": "1", "booth": "booth-1",
    "actor": "m1", "relative": "audio/x.mp3", "name": "0123abcd.wav", "account_id": "1",
    "device": "0123456789abcdef", "interaction_id": "1", "stream_id": "1", "video_id": "1",
    "seq": "0",
}  # fmt: skip
# Well-formed bodies, so the token check (not validation) is what answers.
BODIES = {
    "/api/phone/{token}/ranking": {"client_id": "c" * 16, "position": 1, "ranking": ["water"]},
    "/api/phone/{token}/consent": {"client_id": "c" * 16, "agree": True},
    "/api/phone/{token}/language": {"client_id": "c" * 16, "language": "sv"},
    "/api/phone/{token}/questionnaire": {
        "client_id": "c" * 16, "position": 1, "questionnaire": "trust", "answers": {"x": 1},
    },
}  # fmt: skip


def _routes(app: FastAPI) -> list[tuple[str, str, str]]:
    routes = []
    for template, operations in app.openapi()["paths"].items():
        url = re.sub(r"\{(\w+)\}", lambda m: VALUES[str(m.group(1))], template)
        routes += [(template, method.upper(), url) for method in operations]
    return routes


def _call(client: TestClient, method: str, url: str, template: str, csrf: str | None = None) -> int:
    headers = {"X-CSRF-Token": csrf} if csrf else {}
    body = BODIES.get(template, {}) if method == "POST" else None
    response = client.request(method, url, json=body, headers=headers, follow_redirects=False)
    if response.status_code == 303:
        assert response.headers["location"].startswith("/login"), url
    return response.status_code


def test_anonymous_callers_reach_only_public_routes(client: TestClient, app: FastAPI) -> None:
    for template, method, url in _routes(app):
        if template in PUBLIC:
            continue
        status = _call(client, method, url, template)
        if TOKEN_GUARDED.match(template):
            assert status in (403, 404, 410), f"{method} {template} with a wrong token: {status}"
        else:
            assert status in (303, 401, 403), f"{method} {template} without login: {status}"


def test_wizards_cannot_reach_pi_routes(client: TestClient, app: FastAPI, engine: Engine) -> None:
    add_user(engine, "wiz", "right password", "wizard")
    login(client, "wiz", "right password")
    csrf = csrf_from(client.get("/").text)
    checked = 0
    for template, method, url in _routes(app):
        pi_only = PI_ONLY.match(template) or (method == "POST" and template in PI_ONLY_POSTS)
        if pi_only:
            status = _call(client, method, url, template, csrf)
            assert status == 403, f"{method} {template} as a wizard: {status}"
            checked += 1
    assert checked >= 15


@pytest.mark.parametrize("path", ["/docs", "/openapi.json"])
def test_api_documentation_is_public_and_lists_staff_routes(client: TestClient, path: str) -> None:
    assert client.get(path).status_code == 200
