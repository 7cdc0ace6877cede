"""The PI rotates a booth's display link (the old link and the pages open with it stop at
once) and retires a booth (its link stops working); wizards may not."""

from __future__ import annotations

import re

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import Engine
from starlette.websockets import WebSocketDisconnect

from chameleons.backend.display.tokens import display_path, display_token, signing_key
from tests.backend.display.test_display_pages import database_url, receive
from tests.backend.test_auth import add_user, csrf_from, login

__all__ = ["database_url"]
BOOTH = "booth-1"


def _post(client: TestClient, path: str) -> int:
    token = csrf_from(client.get("/display").text)
    response = client.post(path, data={"csrf_token": token}, follow_redirects=False)
    return response.status_code


def _links(client: TestClient) -> dict[str, str]:
    page = client.get("/display").text
    return dict(re.findall(r'<a href="[^"]*(/display/[^"/]+/[^"]+)" data-booth="([^"]+)"', page))


def _read_until_closed(page: object) -> None:
    while True:
        receive(page)


@pytest.fixture
def pi_client(client: TestClient, engine: Engine) -> TestClient:
    add_user(engine, "pi", "a long pi password", "pi")
    login(client, "pi", "a long pi password")
    return client


def test_rotating_a_link_ends_the_old_one_and_its_open_page(
    pi_client: TestClient, app: FastAPI
) -> None:
    old = display_path(signing_key(app), BOOTH)
    assert pi_client.get(old).status_code == 200
    old_token = display_token(signing_key(app), BOOTH)
    with pi_client.websocket_connect(f"/ws/display/{BOOTH}?token={old_token}") as page:
        assert receive(page)["type"] == "hello"
        assert _post(pi_client, f"/display/{BOOTH}/rotate") == 303
        with pytest.raises(WebSocketDisconnect) as closed:
            _read_until_closed(page)
    assert closed.value.code == 1008
    assert pi_client.get(old).status_code == 404
    new = display_path(signing_key(app), BOOTH, 1)
    assert new in pi_client.get("/display").text
    assert pi_client.get(new).status_code == 200
    with (
        pytest.raises(WebSocketDisconnect),
        pi_client.websocket_connect(f"/ws/display/{BOOTH}?token={old_token}") as again,
    ):
        receive(again)


def test_a_retired_booth_has_no_working_link_until_a_new_one(
    pi_client: TestClient, app: FastAPI
) -> None:
    link = display_path(signing_key(app), BOOTH)
    assert _post(pi_client, f"/display/{BOOTH}/retire") == 303
    assert pi_client.get(link).status_code == 404
    assert f'data-retired="{BOOTH}"' in pi_client.get("/display").text
    assert _post(pi_client, f"/display/{BOOTH}/rotate") == 303
    assert pi_client.get(link).status_code == 404  # the old link stays dead
    assert pi_client.get(display_path(signing_key(app), BOOTH, 1)).status_code == 200


def test_only_the_pi_rotates_and_only_with_the_form_token(
    client: TestClient, app: FastAPI, engine: Engine
) -> None:
    add_user(engine, "wiz", "a long wizard password", "wizard")
    login(client, "wiz", "a long wizard password")
    assert "/rotate" not in client.get("/display").text
    assert _post(client, f"/display/{BOOTH}/rotate") == 403
    assert client.post(f"/display/{BOOTH}/rotate").status_code == 403  # no CSRF token
    assert client.get(display_path(signing_key(app), BOOTH)).status_code == 200
