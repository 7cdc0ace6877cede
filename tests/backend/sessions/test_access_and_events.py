"""Who may do what, the QR code, and the timeline every change leaves behind."""

from __future__ import annotations

import random

from fastapi.testclient import TestClient
from sqlalchemy import Engine, select

from chameleons.backend.db import build_sessionmaker
from chameleons.backend.models import Event
from tests.backend.sessions.conftest import refused
from tests.support.bots import StaffApi, WizardBot, run_session, staff_api


def test_the_session_api_needs_a_staff_login_and_the_csrf_header(
    app: object, wizard: WizardBot
) -> None:
    path = f"/api/sessions/{wizard.session_id}"
    with TestClient(app) as stranger:  # type: ignore[arg-type]
        assert stranger.get(path).status_code == 401
        assert stranger.post(f"{path}/start", json={}).status_code in (401, 403)
        assert stranger.get(f"{path}/phone-qr.svg").status_code == 401
    no_header = wizard.staff.http.post(f"{path}/start", json={})
    assert no_header.status_code == 403
    assert wizard.refresh()["state"] == "pending"


def test_wizards_drive_sessions_but_only_the_pi_sets_up_studies(
    client: TestClient, engine: Engine, study_id: int
) -> None:
    wizard_user = staff_api(client, engine, "wizard")
    assert "Only the PI" in refused(lambda: wizard_user.post("/api/studies", {}), 403)
    plan = f"/api/studies/{study_id}/plan"
    assert "Only the PI" in refused(lambda: wizard_user.post(plan, {"participants": 20}), 403)
    bot = WizardBot.create(wizard_user, study_id)
    assert bot.start()["state"] == "running"
    assert refused(lambda: wizard_user.get("/api/sessions/999999"), 404) == (
        "There is no session 999999."
    )


def test_the_qr_code_is_an_svg_of_the_phone_link(wizard: WizardBot) -> None:
    response = wizard.staff.http.get(wizard.snapshot["phone"]["qr_svg"])
    assert response.status_code == 200
    assert response.headers["content-type"] == "image/svg+xml"
    assert response.text.lstrip().startswith("<svg")
    assert wizard.snapshot["phone"]["url"].endswith(wizard.phone_path)
    assert len(wizard.token) >= 43  # 256 bits, url-safe base64
    code = wizard.snapshot["phone"]["short_code"]
    assert len(code) == 6
    assert not set(code) & set("01258BILOSZ")


def test_every_change_is_an_event_with_server_time(
    client: TestClient, pi: StaffApi, study_id: int, engine: Engine
) -> None:
    result = run_session(pi, client, study_id, random.Random(11))
    with build_sessionmaker(engine)() as db:
        events = list(
            db.scalars(
                select(Event).where(Event.session_id == result.session_id).order_by(Event.id)
            )
        )
    kinds = [e.kind for e in events]
    assert kinds[:2] == ["session.created", "consent.given"]
    assert kinds[2:4] == ["questionnaire.submitted", "session.started"]  # demographics first
    assert kinds[-3:] == [
        "session.final_questionnaire",
        "questionnaire.submitted",
        "session.completed",
    ]
    assert kinds.count("ranking.submitted") == 3
    assert kinds.count("suggestion.proposed") == 9
    assert kinds.count("suggestion.decided") == 9
    # discussion, ranking, negotiation, questionnaire by the wizard; done by the phone
    assert kinds.count("interaction.advanced") == 15
    assert kinds.count("questionnaire.submitted") == 1 + 3 * 4 + 1  # before, 3 x 4, final
    assert all(e.server_time is not None for e in events)
    submitted = [e for e in events if e.source == "participant" and e.kind.endswith("submitted")]
    assert all(e.client_id for e in submitted)
    times = [e.server_time for e in events]
    assert times == sorted(times)
