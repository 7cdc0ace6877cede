"""A wizard action's committed snapshot is kept by the live hub, so the console woken by that
action's events takes it instead of loading the session again, whatever address the console
uses (docs/performance.md); any other change (one the retained state does not include: a
wizard's note) is read from the database. Views made on another server process:
tests/reliability/test_live_fanout.py."""

from __future__ import annotations

import random
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import event
from sqlalchemy.engine import Engine

from chameleons.backend.wizard.console_state import console_state
from tests.backend.wizard.conftest import to_negotiation
from tests.support.bots import ParticipantBot, WizardBot, drive_session

BASE_URL = "http://testserver"  # the TestClient's, as the wizard's requests carry it


@contextmanager
def statements_here() -> Iterator[list[str]]:
    """The SQL statements this thread runs inside the block (the app's server thread idles)."""
    seen: list[str] = []
    here = threading.get_ident()

    def count(_conn: Any, _cursor: Any, statement: str, *_args: Any) -> None:
        if threading.get_ident() == here:
            seen.append(statement)

    event.listen(Engine, "before_cursor_execute", count)
    try:
        yield seen
    finally:
        event.remove(Engine, "before_cursor_execute", count)


def read_console(app: FastAPI, session_id: int, new_events: list[dict[str, Any]] | None) -> Any:
    with app.state.sessionmaker() as db:
        return console_state(db, app.state, session_id, BASE_URL, new_events)


def newest_event(app: FastAPI, session_id: int) -> dict[str, Any]:
    events = read_console(app, session_id, None)["events"]
    return dict(events[-1])


def test_the_console_takes_the_state_a_wizard_action_committed(
    app: FastAPI, client: TestClient, wizard: WizardBot, phone: ParticipantBot
) -> None:
    to_negotiation(wizard, phone)
    answered = wizard.decide(1, 1, True)  # the response's snapshot is retained
    decided = newest_event(app, wizard.session_id)
    assert decided["id"] == answered["version"]
    with statements_here() as statements:
        retained = read_console(app, wizard.session_id, [decided])
    assert statements == []  # nothing loaded: the decision's own snapshot
    fresh = read_console(app, wizard.session_id, None)
    assert retained["session"] == fresh["session"]
    assert retained["prompt_position"] == fresh["prompt_position"] == 1
    assert retained["suggestion_prompts"] == fresh["suggestion_prompts"]
    assert retained["events"] == [decided]
    assert retained["events_delta"] is True


class CheckedPhone(ParticipantBot):
    """After each of its submissions: the console woken by it takes the state the
    submission committed, without a statement, and that state is the database's."""

    def __init__(self, app: FastAPI, client: TestClient, wizard: WizardBot) -> None:
        super().__init__(client, wizard.token)
        self.app, self.session_id, self.checked = app, wizard.session_id, 0

    def _send(self, kind: str, body: dict[str, Any]) -> dict[str, Any]:
        receipt = super()._send(kind, body)
        newest = newest_event(self.app, self.session_id)
        with statements_here() as statements:
            retained = read_console(self.app, self.session_id, [newest])
        assert statements == [], kind  # the submission's own state, kept
        assert retained["session"] == read_console(self.app, self.session_id, None)["session"]
        self.checked += 1
        return receipt


def test_the_console_takes_the_state_a_phones_answer_committed(
    app: FastAPI, client: TestClient, wizard: WizardBot
) -> None:
    """A whole session: every ranking and questionnaire page the phone submits leaves the
    console's state in the live hub (docs/performance.md), the same as a fresh read."""
    phone = CheckedPhone(app, client, wizard)
    result = drive_session(wizard, phone, random.Random(3))
    assert result.snapshot["state"] == "complete"
    kinds = {sent["kind"] for sent in phone.sent}
    assert kinds == {"ranking", "questionnaire"}
    assert phone.checked == len(phone.sent) >= 2 * len(result.snapshot["interactions"])


def test_a_change_the_retained_state_does_not_hold_is_read_from_the_database(
    app: FastAPI, client: TestClient, wizard: WizardBot, phone: ParticipantBot
) -> None:
    before = wizard.start()
    # A wizard's note makes no snapshot; the one the start kept is now older.
    wizard.staff.post(f"/api/sessions/{wizard.session_id}/notes", {"text": "laughed"})
    noted = newest_event(app, wizard.session_id)
    assert noted["id"] > before["version"]
    with statements_here() as statements:
        state = read_console(app, wizard.session_id, [noted])
    assert statements  # the session was loaded: the retained snapshot is older
    assert state["session"]["version"] == noted["id"]
    assert state["session"] == read_console(app, wizard.session_id, None)["session"]


def test_a_console_on_another_address_gets_its_own_links(
    app: FastAPI, client: TestClient, wizard: WizardBot
) -> None:
    started = wizard.start()
    started_event = newest_event(app, wizard.session_id)
    assert started_event["id"] == started["version"]
    with app.state.sessionmaker() as db, statements_here() as statements:
        state = console_state(
            db, app.state, wizard.session_id, "http://lab.example", [started_event]
        )
    assert statements == []  # the retained snapshot, with the links of this console's address
    phone = state["session"]["phone"]
    assert phone["url"] == f"http://lab.example/p/{wizard.token}"
    assert phone["join_url"] == "http://lab.example/join"
    assert started["phone"]["url"] == f"{BASE_URL}/p/{wizard.token}"  # the wizard's own


def test_a_read_only_console_read_takes_the_version_with_the_session(
    app: FastAPI, client: TestClient, wizard: WizardBot, phone: ParticipantBot
) -> None:
    """The console's refresh (a read-only session) reads the session's newest event id in
    the session's own statement, not in one of its own; the version is the same."""
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    phone.submit_ranking(1, list(wizard.interaction(1)["presented_order"]))
    submitted = newest_event(app, wizard.session_id)
    with app.state.read_sessionmaker() as db, statements_here() as statements:
        state = console_state(db, app.state, wizard.session_id, BASE_URL, None)  # a load
    assert state["session"]["version"] == submitted["id"]
    assert not any(s.lstrip().startswith("SELECT max(event.id)") for s in statements)
    assert any("max(event.id)" in s and "FROM session" in s for s in statements)
    with statements_here() as written:  # a session that may write asks on its own, as before
        assert read_console(app, wizard.session_id, None)["session"] == state["session"]
    assert any(s.lstrip().startswith("SELECT max(event.id)") for s in written)
