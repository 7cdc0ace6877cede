from __future__ import annotations

from pathlib import Path

from fastapi.testclient import TestClient

from chameleons.backend.app import create_app
from chameleons.settings import Settings


def test_healthz_ok_at_head(client: TestClient) -> None:
    response = client.get("/healthz")
    assert response.status_code == 200
    assert response.json()["status"] == "ok"


def test_healthz_503_on_empty_database(tmp_path: Path, settings: Settings) -> None:
    empty = settings.model_copy(update={"database_url": f"sqlite:///{tmp_path / 'empty.db'}"})
    with TestClient(create_app(empty)) as client:
        response = client.get("/healthz")
    assert response.status_code == 503
    assert "chameleons db upgrade" in response.json()["reason"]


def test_healthz_503_when_database_unreachable(settings: Settings) -> None:
    unreachable = settings.model_copy(
        update={"database_url": "postgresql://nobody@127.0.0.1:1/none?connect_timeout=1"}
    )
    with TestClient(create_app(unreachable)) as client:
        response = client.get("/healthz")
    assert response.status_code == 503
    assert "unreachable" in response.json()["reason"]
