"""Which face the display page paints: the link's ?renderer=, the booth's default (set by the
PI on /display), the server's setting; a lab's head file; the import map's CSP hash."""

from __future__ import annotations

import base64
import hashlib
import re

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from chameleons.backend.display.renderers import heads_dir
from chameleons.backend.display.tokens import display_path, signing_key
from chameleons.settings import Settings
from tests.backend.display.test_display_pages import database_url
from tests.backend.test_auth import add_user, csrf_from, login
from tests.support.head3d import sphere_head

__all__ = ["database_url"]
BOOTH = "booth-1"


def choice(client: TestClient, app: FastAPI, query: str = "") -> tuple[str, str, str]:
    page = client.get(display_path(signing_key(app), BOOTH) + query).text
    renderer = re.search(r'data-renderer="([^"]*)"', page)
    source = re.search(r'data-renderer-source="([^"]*)"', page)
    head = re.search(r'data-head-url="([^"]*)"', page)
    assert renderer is not None
    assert source is not None
    assert head is not None
    return renderer.group(1), source.group(1), head.group(1)


@pytest.fixture
def pi_client(client: TestClient, engine: Engine) -> TestClient:
    add_user(engine, "pi", "a long pi password", "pi")
    login(client, "pi", "a long pi password")
    return client


def set_defaults(client: TestClient, renderer: str, head: str = "") -> int:
    token = csrf_from(client.get("/display").text)
    form = {"csrf_token": token, "renderer": renderer, "head": head}
    response = client.post(f"/display/{BOOTH}/defaults", data=form, follow_redirects=False)
    return response.status_code


def test_the_link_the_booth_and_the_setting_choose_in_that_order(
    pi_client: TestClient, app: FastAPI
) -> None:
    assert choice(pi_client, app) == ("2d", "setting", "")
    assert choice(pi_client, app, "?renderer=3d") == ("3d", "link", "")
    assert set_defaults(pi_client, "3d") == 303
    assert choice(pi_client, app) == ("3d", "booth", "")
    assert choice(pi_client, app, "?renderer=2d") == ("2d", "link", "")
    assert choice(pi_client, app, "?renderer=4d") == ("3d", "booth", "")
    assert 'value="3d" selected' in pi_client.get("/display").text
    assert set_defaults(pi_client, "") == 303
    assert choice(pi_client, app) == ("2d", "setting", "")


def test_the_server_setting_is_the_last_word(client: TestClient, settings: Settings) -> None:
    from chameleons.backend.app import create_app

    app = create_app(settings.model_copy(update={"display_renderer": "3d"}))
    with TestClient(app) as other:
        assert choice(other, app) == ("3d", "setting", "")
    app.state.engine.dispose()


def test_a_bad_face_or_a_missing_head_is_refused_with_a_sentence(pi_client: TestClient) -> None:
    assert set_defaults(pi_client, "4d") == 422
    token = csrf_from(pi_client.get("/display").text)
    form = {"csrf_token": token, "renderer": "3d", "head": "nope.glb"}
    response = pi_client.post(f"/display/{BOOTH}/defaults", data=form)
    assert response.status_code == 422
    assert "No head file 'nope.glb'" in response.json()["detail"]


def test_a_wizard_cannot_change_the_booth_default(client: TestClient, engine: Engine) -> None:
    add_user(engine, "wiz", "a long wizard password", "wizard")
    login(client, "wiz", "a long wizard password")
    assert set_defaults(client, "3d") == 403


def test_a_labs_head_file_is_offered_served_and_chosen(
    pi_client: TestClient, app: FastAPI, settings: Settings
) -> None:
    folder = heads_dir(settings)
    folder.mkdir(parents=True)
    glb = sphere_head({"jawOpen": ((0, -6, 8), (0, -2, 1), 3.0)})
    (folder / "lab-head.glb").write_bytes(glb)
    (folder / "notes.txt").write_text("not a head")
    page = pi_client.get("/display").text
    assert '<option value="lab-head.glb"' in page
    assert "notes.txt" not in page
    url = "/display-heads/lab-head.glb"
    assert choice(pi_client, app, "?head=lab-head.glb") == ("2d", "setting", url)
    assert choice(pi_client, app, "?head=../secret.glb")[2] == ""
    assert set_defaults(pi_client, "3d", "lab-head.glb") == 303
    assert choice(pi_client, app) == ("3d", "booth", url)
    served = pi_client.get(url)
    assert served.status_code == 200
    assert served.content == glb
    assert pi_client.get("/display-heads/notes.txt").status_code == 404
    assert pi_client.get("/display-heads/..%2Fchameleons.sqlite3").status_code == 404


def test_the_import_map_is_the_only_inline_script_and_its_hash_is_allowed(
    client: TestClient, app: FastAPI
) -> None:
    response = client.get(display_path(signing_key(app), BOOTH))
    inline = re.findall(r"<script([^>]*)>(.*?)</script>", response.text, re.S)
    bodies = [body for attrs, body in inline if "src=" not in attrs]
    assert len(bodies) == 1
    assert '"three"' in bodies[0]
    digest = base64.b64encode(hashlib.sha256(bodies[0].encode()).digest()).decode()
    policy = response.headers["content-security-policy"]
    assert f"script-src 'self' 'sha256-{digest}'" in policy
    assert "unsafe-inline" not in policy
    assert "unsafe-eval" not in policy
    # Other pages keep the plain policy.
    assert "sha256" not in client.get("/login").headers["content-security-policy"]
