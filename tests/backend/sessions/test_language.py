"""A session's language: chosen at registration (the study's default otherwise), changed on
the phone's first page before consent, shown to the wizard and the PI, exported."""

from __future__ import annotations

import csv
import random
from pathlib import Path

from fastapi.testclient import TestClient
from sqlalchemy import Engine, select

from chameleons.backend.db import build_sessionmaker
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.models import Event
from tests.backend.sessions.conftest import refused
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, drive_session


def read_rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8", newline="") as handle:
        return list(csv.DictReader(handle))


def test_registration_takes_a_declared_language_or_the_default(pi: StaffApi, study_id: int) -> None:
    default = pi.post("/api/sessions", {"study_id": study_id})
    assert default["language"] == "en"
    assert default["languages"] == ["en", "sv"]
    swedish = pi.post("/api/sessions", {"study_id": study_id, "language": "sv"})
    assert swedish["language"] == "sv"
    message = refused(
        lambda: pi.post("/api/sessions", {"study_id": study_id, "language": "de"}), 422
    )
    assert message == "The study has no language 'de' (its languages: en, sv)."


def test_the_phone_offers_the_languages_until_consent(
    client: TestClient, wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    state = phone.state()
    assert state["language"] == "en"
    assert state["languages"] == [
        {"code": "en", "name": "English"},
        {"code": "sv", "name": "Svenska"},
    ]
    changed = phone.choose_language("sv")
    assert changed["state"]["language"] == "sv"
    assert changed["state"]["consent"]["title"] == "Innan vi börjar"
    assert "Ansluter…" in client.get(wizard.phone_path).text
    assert wizard.refresh()["language"] == "sv"
    assert refused(lambda: phone.choose_language("fi"), 422) == (
        "Studien finns inte på det språket."
    )
    after = phone.consent(True)["state"]
    assert "languages" not in after
    assert refused(lambda: phone.choose_language("en"), 409) == (
        "Språket kan bara ändras innan studien börjar."
    )
    with build_sessionmaker(engine)() as db:
        changes = db.scalars(select(Event).where(Event.kind == "phone.language")).all()
        assert [c.payload for c in changes] == [{"from": "en", "to": "sv"}]


def test_the_wizard_registers_in_a_language_and_sees_it(
    client: TestClient, pi: StaffApi, study_id: int
) -> None:
    page = client.get("/wizard").text
    assert '<option value="sv">sv</option>' in page
    opened = client.post(
        "/wizard/sessions",
        data={
            "csrf_token": pi.csrf,
            "study_id": str(study_id),
            "booth": "booth-1",
            "language": "sv",
        },
        follow_redirects=False,
    )
    assert opened.status_code == 303
    console = client.get(opened.headers["location"]).text
    assert (
        '<span id="bar-language" class="tag" title="The participant\'s language">sv</span>'
        in console
    )
    session_id = opened.headers["location"].rsplit("/", 1)[-1]
    assert (
        '<strong id="session-language">sv</strong>' in client.get(f"/pi/sessions/{session_id}").text
    )


def test_the_export_records_each_participants_language(
    client: TestClient, pi: StaffApi, study_id: int, engine: Engine, tmp_path: Path
) -> None:
    english = WizardBot.create(pi, study_id)
    swedish = WizardBot.create(pi, study_id)
    ParticipantBot(client, swedish.token).choose_language("sv")
    for wizard in (english, swedish):
        drive_session(
            wizard, ParticipantBot(client, wizard.token), random.Random(wizard.session_id)
        )
    with build_sessionmaker(engine)() as db:
        export_to_directory(db, ExportRequest(), tmp_path)
    participants = {r["session"]: r["language"] for r in read_rows(tmp_path / "participants.csv")}
    assert participants == {str(english.session_id): "en", str(swedish.session_id): "sv"}
    answers = read_rows(tmp_path / "questionnaire.csv")
    by_session = {(r["session"], r["language"]) for r in answers}
    assert by_session == {(str(english.session_id), "en"), (str(swedish.session_id), "sv")}
    # One version id for the wording in every language.
    versions = {(r["questionnaire"], r["language"]): r["version"] for r in answers}
    assert versions[("trust", "en")] == versions[("trust", "sv")] == "rau2009-v1"
    book = read_rows(tmp_path / "codebook.csv")
    entries = {(r["table"], r["column"]): r for r in book if r["column"] == "language"}
    assert set(entries) == {("participants", "language"), ("questionnaire", "language")}
    assert all(e["description"] and e["values"] == "en, sv" for e in entries.values())
