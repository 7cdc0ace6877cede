"""The session picker registers the next participant and opens their session; refusals
keep nothing and say why; the console page needs a login and a real session."""

from __future__ import annotations

import re

from fastapi.testclient import TestClient

from tests.support.bots import StaffApi, study_with_plan


def form(client: TestClient) -> str:
    match = re.search(r'name="csrf_token" value="([^"]+)"', client.get("/wizard").text)
    assert match is not None
    return match.group(1)


def test_the_picker_registers_the_next_participant_and_opens_the_console(
    client: TestClient, pi: StaffApi
) -> None:
    study_id = study_with_plan(pi, participants=2)
    response = client.post(
        "/wizard/sessions",
        data={"csrf_token": form(client), "study_id": study_id, "booth": "booth-2"},
        follow_redirects=False,
    )
    assert response.status_code == 303
    session_id = int(response.headers["location"].rsplit("/", 1)[-1])
    snapshot = pi.get(f"/api/sessions/{session_id}")
    assert snapshot["participant"]["code"] == "P001"
    assert snapshot["booth"] == "booth-2"
    page = client.get(response.headers["location"])
    assert page.status_code == 200
    assert f'data-session-id="{session_id}"' in page.text
    assert snapshot["phone"]["short_code"] in page.text
    assert f'href="/wizard/sessions/{session_id}"' in client.get("/wizard").text


def test_a_rehearsal_gets_a_rehearsal_code(client: TestClient, pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=1)
    data = {"csrf_token": form(client), "study_id": study_id, "rehearsal": "true"}
    response = client.post("/wizard/sessions", data=data, follow_redirects=False)
    session_id = int(response.headers["location"].rsplit("/", 1)[-1])
    snapshot = pi.get(f"/api/sessions/{session_id}")
    assert snapshot["participant"]["code"] == "R001"
    assert snapshot["is_rehearsal"] is True


def test_a_refusal_is_shown_and_keeps_nothing(client: TestClient, pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=1)
    data = {"csrf_token": form(client), "study_id": study_id}
    assert client.post("/wizard/sessions", data=data, follow_redirects=False).status_code == 303
    again = client.post("/wizard/sessions", data=data, follow_redirects=False)
    assert again.status_code == 409
    assert "All 1 plan rows are taken" in again.text
    unknown = {**data, "participant_code": "P404"}
    refused = client.post("/wizard/sessions", data=unknown, follow_redirects=False)
    assert refused.status_code == 409
    assert "has no participant" in refused.text
    people = pi.get(f"/api/studies/{study_id}/participants")
    assert [p["code"] for p in people] == ["P001"]


def test_pages_need_a_login_and_a_csrf_token(client: TestClient, pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=1)
    refused = client.post("/wizard/sessions", data={"study_id": study_id}, follow_redirects=False)
    assert refused.status_code == 403
    assert client.get("/wizard/sessions/999").status_code == 404
    client.cookies.clear()
    response = client.get("/wizard", follow_redirects=False)
    assert response.status_code == 303
    assert response.headers["location"].startswith("/login")


def test_a_registration_is_undone_when_the_session_cannot_open(
    client: TestClient, pi: StaffApi
) -> None:
    study_id = int(pi.post("/api/studies", {"plan_seed": 3})["id"])  # no plan yet
    data = {"csrf_token": form(client), "study_id": study_id, "rehearsal": "true"}
    refused = client.post("/wizard/sessions", data=data, follow_redirects=False)
    assert refused.status_code == 409
    assert "no plan yet" in refused.text
    assert pi.get(f"/api/studies/{study_id}/participants") == []
