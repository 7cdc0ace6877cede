"""The phone pages and the phone's API speak the session's language."""

from __future__ import annotations

import json
import re

from fastapi.testclient import TestClient
from sqlalchemy import Engine, update

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import Session as SessionRow
from tests.backend.sessions.conftest import refused
from tests.support.bots import ParticipantBot, WizardBot


def set_language(engine: Engine, session_id: int, language: str) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        db.execute(update(SessionRow).where(SessionRow.id == session_id).values(language=language))


def script_messages(html: str) -> dict[str, str]:
    found = re.search(r'<script type="application/json" id="messages">(.*?)</script>', html, re.S)
    assert found is not None
    return dict(json.loads(found.group(1)))


def test_the_phone_page_is_english_by_default(client: TestClient, wizard: WizardBot) -> None:
    html = client.get(wizard.phone_path).text
    assert '<html lang="en" dir="ltr">' in html
    assert "Connecting…" in html
    assert script_messages(html) == {}


def test_a_swedish_session_gets_swedish_pages_errors_and_script_strings(
    client: TestClient, wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    set_language(engine, wizard.session_id, "sv")
    html = client.get(wizard.phone_path).text
    assert '<html lang="sv" dir="ltr">' in html
    assert "Ansluter…" in html
    assert "Connecting…" not in html
    messages = script_messages(html)
    assert messages["Submit my ranking"] == "Skicka min rangordning"
    assert messages["Part {page} of {pages}"] == "Del {page} av {pages}"
    # The default consent buttons come translated; an error sentence too.
    state = phone.state()
    assert state["consent"]["title"] == "Innan vi börjar"  # the study's own Swedish text
    assert state["consent"]["agree"] == "Jag samtycker till att delta"
    assert state["consent"]["paragraphs"][0].startswith("Du är inbjuden till en studie")
    assert refused(lambda: phone.submit_questionnaire(-1, "demographics", {}), 409) == (
        "Frågorna är inte öppna just nu."
    )
    receipt = phone.consent(True)
    assert refused(lambda: phone.consent(False), 409) == "Ditt samtycke är redan registrerat."
    before = receipt["state"]["questionnaire"]
    assert before["title"] == "Om dig"
    assert before["items"][0]["options"][-1]["label"] == "Vill inte uppge"
    assert refused(lambda: phone.submit_questionnaire(-1, "demographics", {"x": 1}), 422) == (
        "Okända frågor: x."
    )


def test_join_follows_the_browser_language(client: TestClient) -> None:
    swedish = client.get("/join", headers={"Accept-Language": "sv-SE,sv;q=0.9,en;q=0.8"})
    assert "Anslut till sessionen" in swedish.text
    wrong = client.post("/join", data={"code": "ZZZZZZ"}, headers={"Accept-Language": "sv"})
    assert wrong.status_code == 404
    assert "Koden hör inte till någon pågående session" in wrong.text
    other = client.get("/join", headers={"Accept-Language": "de-DE,fr;q=0.5"})
    assert "Join the session" in other.text
    assert "Join the session" in client.get("/join").text
