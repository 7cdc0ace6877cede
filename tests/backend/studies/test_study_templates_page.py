"""The Studies page lists the shipped templates and creates a study from one (issue 31)."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from tests.support.bots import StaffApi, staff_api


@pytest.fixture
def pi(client: TestClient, engine: Engine) -> StaffApi:
    return staff_api(client, engine, "pi")


def test_the_studies_page_creates_a_study_from_a_template(client: TestClient, pi: StaffApi) -> None:
    page = client.get("/studies")
    assert page.status_code == 200
    for name in ("delay_sweep", "channels", "partial_full", "embodiment"):
        assert f'<option value="{name}">' in page.text
    created = client.post("/studies", data={"csrf_token": pi.csrf, "template": "partial_full"},
                          follow_redirects=False)  # fmt: skip
    assert created.status_code == 303
    (study,) = pi.get("/api/studies")
    assert study["name"] == "Partial versus full mimicry"
    unknown = client.post("/studies", data={"csrf_token": pi.csrf, "template": "nope"})
    assert unknown.status_code == 409
    assert "There is no template &#39;nope&#39;." in unknown.text
