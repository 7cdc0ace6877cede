"""The procedure as study data, through the phone's API: consent first (the wizard cannot
start before it), skippable questions about the participant, declining ends the session
with nothing but the refusal, the manipulation check's robot answer resolved to a
condition in the export and counted on the analysis page, and the debriefing at the end."""

from __future__ import annotations

import csv
import random
from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient
from sqlalchemy import Engine, func, select

from chameleons.backend.db import build_sessionmaker
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.models import Event, Participant, QuestionnaireResponse
from chameleons.backend.models import Session as SessionRow
from tests.backend.sessions.conftest import refused
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, drive_session


def _session(engine: Engine, session_id: int) -> SessionRow:
    with build_sessionmaker(engine)() as db:
        row = db.get(SessionRow, session_id)
        assert row is not None
        return row


def _answers(engine: Engine, **where: Any) -> list[QuestionnaireResponse]:
    with build_sessionmaker(engine)() as db:
        return list(db.scalars(select(QuestionnaireResponse).filter_by(**where)))


def test_the_session_cannot_start_before_consent_and_consent_is_recorded_once(
    wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    state = phone.state()
    assert state["view"] == "consent"
    assert state["consent"]["agree"] == "I agree to take part"
    assert "Taking part is voluntary." in " ".join(state["consent"]["paragraphs"])
    message = refused(lambda: wizard.start(prepare=False), 409)
    assert message.startswith("The session cannot start before the participant has given consent.")
    assert refused(lambda: phone.submit_questionnaire(-1, "demographics", {}), 409) == (
        "These questions are not open at the moment."
    )
    receipt = phone.consent(True, client_id="consent-once-1")
    assert receipt["state"]["view"] == "questionnaire"
    assert receipt["state"]["before"] is True
    assert phone.consent(True, client_id="consent-once-1")["duplicate"] is True
    assert refused(lambda: phone.consent(False), 409) == "Your consent was already recorded."
    row = _session(engine, wizard.session_id)
    assert row.consent_at is not None
    assert row.state == "pending"
    message = refused(lambda: wizard.start(prepare=False), 409)
    assert "has not answered the questions before the session" in message


def test_the_questions_before_are_skippable_and_stored_as_skipped(
    wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    phone.consent(True)
    wording = phone.state()["questionnaire"]
    assert wording["id"] == "demographics"
    assert [i["id"] for i in wording["items"]] == ["age_band", "gender", "robot_experience"]
    assert all(not i["required"] for i in wording["items"])
    assert wording["items"][1]["options"][0] == {"id": "woman", "label": "Woman"}
    bad = {"gender": "robot"}
    assert refused(lambda: phone.submit_questionnaire(-1, "demographics", bad), 422) == (
        "Please choose one of the answers to question 2."
    )
    receipt = phone.submit_questionnaire(-1, "demographics", {"robot_experience": "never"})
    assert receipt["state"] == {**receipt["state"], "view": "welcome"}
    stored = {r.item: (r.text, r.skipped, r.position) for r in _answers(engine)}
    assert stored == {
        "age_band": (None, True, -1),
        "gender": (None, True, -1),
        "robot_experience": ("never", False, -1),
    }
    assert wizard.start(prepare=False)["state"] == "running"


def test_declining_ends_the_session_and_keeps_only_the_refusal(
    wizard: WizardBot, phone: ParticipantBot, engine: Engine, client: TestClient
) -> None:
    receipt = phone.consent(False)
    assert receipt["state"] == {**receipt["state"], "view": "ended", "declined": True}
    row = _session(engine, wizard.session_id)
    assert (row.state, row.end_reason, row.consent_at, row.started_at) == (
        "ended", "consent_declined", None, None
    )  # fmt: skip
    with build_sessionmaker(engine)() as db:
        participant = db.get(Participant, row.participant_id)
        assert participant is not None
        assert (participant.status, participant.consent_at) == ("declined", None)
        assert participant.plan_row_id is None  # the row goes to the next participant
        answers = db.scalar(select(func.count()).select_from(QuestionnaireResponse))
        kinds = list(db.scalars(select(Event.kind).where(Event.session_id == row.id)))
    assert answers == 0
    assert kinds == ["session.created", "consent.declined"]
    page = client.get(wizard.phone_path)
    assert page.status_code == 410
    assert "You have chosen not to take part" in page.text
    assert "What this study was about" not in page.text  # nothing happened to debrief
    assert refused(lambda: wizard.start(prepare=False), 409).startswith(
        "The session has already started (it is ended)."
    )


def test_manipulation_check_is_exported_by_condition_and_counted_on_the_analysis_page(
    client: TestClient, pi: StaffApi, study_id: int, engine: Engine, tmp_path: Path
) -> None:
    named: list[str] = []
    for seed in (1, 2, 3):
        wizard = WizardBot.create(pi, study_id)
        phone = ParticipantBot(client, wizard.token)
        result = drive_session(wizard, phone, random.Random(seed))
        final = next(s for s in phone.sent if s.get("questionnaire") == "final")
        picked = final["answers"]["imitating_robot"]
        if picked != "dont_know":
            named.append(result.snapshot["interactions"][picked - 1]["condition"])
        page = client.get(wizard.phone_path)  # the link has stopped; the debriefing stays
        assert "What this study was about" in page.text
        assert "imitated your own head movements" in page.text
    with build_sessionmaker(engine)() as db:
        export_to_directory(db, ExportRequest(), tmp_path)
    with (tmp_path / "questionnaire.csv").open(encoding="utf-8") as handle:
        rows = [r for r in csv.DictReader(handle) if r["item"] == "imitating_robot"]
    assert sorted(r["named_condition"] for r in rows if r["named_condition"]) == sorted(named)
    api = client.get("/api/pi/analysis", params={"study": study_id}).json()
    checks = {c["item"]: c for c in api["manipulation_check"]}
    robot = checks["imitating_robot"]
    assert list(robot["counts"]) == ["natural", "copy", "still", "dont_know"]
    for condition in ("natural", "copy", "still"):
        assert robot["counts"][condition] == named.count(condition)
    assert robot["answered"] + robot["skipped"] == 3
    assert sum(checks["noticed_imitation"]["counts"].values()) == 3
    html = client.get("/pi/analysis", params={"study": study_id}).text
    assert 'data-item="imitating_robot"' in html
    assert '<tr data-answer="copy"><td>Copy' in html
