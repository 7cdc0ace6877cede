"""What a questionnaire page costs the database: the answers already stored are read once
per submission, not once per question asked of them (may it store, is the part done, what
does the phone see next), and the staff check is one statement (docs/performance.md)."""

from __future__ import annotations

import random
import re

from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import select

from chameleons.backend.auth import sessions
from chameleons.backend.events.unit_of_work import write_session
from chameleons.backend.models import StaffUser
from chameleons.backend.phone.submissions import submit
from chameleons.backend.sessions.answers import answered, submit_questionnaire
from chameleons.backend.sessions.bot import answers_for, new_client_id
from chameleons.backend.sessions.consent import BEFORE_POSITION
from chameleons.backend.sessions.flow import load_by_token
from tests.backend.wizard.test_retained_state import statements_here
from tests.support.bots import ParticipantBot, WizardBot

ANSWERED_READ = re.compile(r"SELECT DISTINCT questionnaire_response\.", re.IGNORECASE)


def _answer_first_page(app: FastAPI, token: str, page: dict[str, object]) -> list[str]:
    answers = answers_for(page, random.Random(1))
    client_id = new_client_id()
    with statements_here() as statements, write_session(app.state.sessionmaker,
                                                        app.state.live_hub) as db:  # fmt: skip
        receipt = submit(
            db,
            token,
            client_id,
            lambda flow: submit_questionnaire(
                flow, client_id, BEFORE_POSITION, str(page["id"]), answers
            ),
        )
    assert receipt["saved"]
    assert not receipt["duplicate"]
    return statements


def test_a_questionnaire_page_reads_the_stored_answers_once(
    app: FastAPI, client: TestClient, wizard: WizardBot, phone: ParticipantBot
) -> None:
    state = phone.consent(True)["state"]
    assert state["view"] == "questionnaire"
    assert state["before"]
    statements = _answer_first_page(app, wizard.token, state["questionnaire"])
    reads = [s for s in statements if ANSWERED_READ.search(s)]
    assert len(reads) == 1, reads
    # ... and what it kept is what the database holds now.
    with app.state.sessionmaker() as db:
        fresh = load_by_token(db, wizard.token, lock=False)
        assert state["questionnaire"]["id"] in answered(fresh, BEFORE_POSITION)


def test_the_staff_check_is_one_statement(app: FastAPI, wizard: WizardBot) -> None:
    with app.state.sessionmaker() as db:
        user = db.scalars(select(StaffUser).where(StaffUser.role == "pi")).first()
        assert user is not None
        key = sessions.start(db, user, hours=1)
        db.commit()
    with app.state.sessionmaker() as db, statements_here() as statements:
        found = sessions.staff_of(db, {sessions.SESSION_KEY: key})
    assert found is not None
    assert found.id == user.id
    assert len(statements) == 1, statements
