"""Every kind of participant submission, sent again with its client id (the phone's retry
after a lost answer), gets the stored receipt and is stored once; and a first submission
does not look its client id up (issue 34: the look-up runs only when storing fails)."""

from __future__ import annotations

import random
import re
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from fastapi import FastAPI
from sqlalchemy import Engine, event, func, select

from chameleons.backend.db import build_sessionmaker
from chameleons.backend.models import Event
from chameleons.backend.sessions.bot import answers_for
from chameleons.backend.sessions.consent import BEFORE_POSITION
from tests.backend.sessions.conftest import refused
from tests.support.bots import ParticipantBot, WizardBot

CLIENT_ID_LOOKUP = re.compile(r"WHERE .*event\.client_id = ", re.IGNORECASE | re.DOTALL)


@contextmanager
def app_statements(app: FastAPI) -> Iterator[list[str]]:
    """Every statement the app's engine runs inside the block, whichever thread runs it."""
    seen: list[str] = []
    lock = threading.Lock()

    def note(_conn: Any, _cursor: Any, statement: str, *_args: Any) -> None:
        with lock:
            seen.append(statement)

    engine = app.state.engine
    event.listen(engine, "before_cursor_execute", note)
    try:
        yield seen
    finally:
        event.remove(engine, "before_cursor_execute", note)


def _stored(engine: Engine, session_id: int, client_id: str) -> int:
    with build_sessionmaker(engine)() as db:
        query = (
            select(func.count())
            .select_from(Event)
            .filter_by(session_id=session_id, client_id=client_id)
        )
        return int(db.scalar(query) or 0)


def _twice(
    app: FastAPI, engine: Engine, session_id: int, client_id: str, send: Callable[[], Any]
) -> dict[str, Any]:
    with app_statements(app) as statements:
        first = send()
    assert first["saved"] is True
    assert first["duplicate"] is False
    assert not [s for s in statements if CLIENT_ID_LOOKUP.search(s)], statements
    again = send()
    assert again["duplicate"] is True
    for key in ("client_id", "kind", "stored", "saved_at"):
        assert again[key] == first[key], key
    assert _stored(engine, session_id, client_id) == 1
    return dict(first)


def test_each_kind_sent_twice_is_stored_once_and_first_sends_look_nothing_up(
    app: FastAPI, wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    session = wizard.session_id
    # The language again (storing it again is allowed: the event's unique client id refuses
    # the copy), then consent (a second consent is refused: its check does).
    chosen = _twice(app, engine, session, "language-id-0001",
                    lambda: phone._send("language", {"client_id": "language-id-0001",
                                                     "language": "en"}))  # fmt: skip
    assert chosen["kind"] == "phone.language"
    receipt = _twice(app, engine, session, "consent-id-00001",
                     lambda: phone.consent(True, client_id="consent-id-00001"))  # fmt: skip
    page = receipt["state"]["questionnaire"]
    answers = answers_for(page, random.Random(1))
    _twice(app, engine, session, "page-id-00000001",
           lambda: phone.submit_questionnaire(BEFORE_POSITION, page["id"], answers,
                                              client_id="page-id-00000001"))  # fmt: skip
    while (state := phone.state())["view"] == "questionnaire":  # the rest of the pages
        page = state["questionnaire"]
        phone.submit_questionnaire(BEFORE_POSITION, page["id"], answers_for(page, random.Random(2)))
    wizard.start(prepare=False)
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    ranking = list(wizard.interaction(1)["presented_order"])
    ranked = _twice(
        app, engine, session, "ranking-id-00001",
        lambda: phone.submit_ranking(1, ranking, client_id="ranking-id-00001"),
    )  # fmt: skip
    assert ranked["stored"] == {"position": 1, "ranking": ranking}
    assert wizard.refresh()["interactions"][0]["initial_ranking"] == ranking


def test_a_refused_first_submission_is_still_refused(
    wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    """A failed store looks the client id up; finding nothing, the refusal stands and
    nothing is stored."""
    wizard.start()
    ranking = list(wizard.interaction(1)["presented_order"])
    message = refused(lambda: phone.submit_ranking(1, ranking, client_id="early-id-0000001"), 409)
    assert message == "The ranking is not open at the moment."
    assert _stored(engine, wizard.session_id, "early-id-0000001") == 0
