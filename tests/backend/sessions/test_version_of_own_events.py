"""The session's version (its newest event id) after a change: on SQLite the transaction
that inserted the session's event knows it without ``SELECT max(event.id)`` (it holds the
write lock until it ends, so no other event can come in between; issue 34), on
PostgreSQL it is still read. Either way it equals what the database holds."""

from __future__ import annotations

from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import delete, func, select

from chameleons.backend.events import repository as events
from chameleons.backend.events.hub import session_channel
from chameleons.backend.events.unit_of_work import write_session
from chameleons.backend.models import Event
from chameleons.backend.phone.submissions import submit
from chameleons.backend.sessions.answers import submit_ranking
from chameleons.backend.sessions.bot import new_client_id
from chameleons.backend.sessions.flow import load, load_by_token
from chameleons.backend.sessions.snapshot import CONSOLE_VIEW
from tests.backend.wizard.test_retained_state import statements_here
from tests.support.bots import WizardBot

NEWEST = "max(event.id)"


def _newest_in_database(app: FastAPI, session_id: int) -> int:
    with app.state.sessionmaker() as db:
        return int(db.scalar(select(func.max(Event.id)).where(Event.session_id == session_id)))


def _at_ranking(wizard: WizardBot) -> list[str]:
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    return list(wizard.interaction(1)["presented_order"])


def test_a_phones_ranking_knows_its_version_without_asking_on_sqlite(
    app: FastAPI, client: TestClient, wizard: WizardBot
) -> None:
    ranking = _at_ranking(wizard)
    client_id = new_client_id()
    with statements_here() as statements, write_session(app.state.sessionmaker,
                                                        app.state.live_hub) as db:  # fmt: skip
        receipt = submit(
            db, wizard.token, client_id,
            lambda flow: submit_ranking(flow, client_id, 1, ranking),
        )  # fmt: skip
        sqlite = db.get_bind().dialect.name == "sqlite"
    asked = [s for s in statements if NEWEST in s.lower()]
    if sqlite:
        assert asked == [], statements
    else:
        assert len(asked) == 1, statements
    newest = _newest_in_database(app, wizard.session_id)
    assert receipt["state"]["version"] == newest  # the phone's view
    retained = app.state.live_hub.retained(session_channel(wizard.session_id), CONSOLE_VIEW)
    assert retained is not None
    assert retained["version"] == newest  # the console's state


def test_a_transaction_that_inserted_nothing_asks(
    app: FastAPI, client: TestClient, wizard: WizardBot
) -> None:
    wizard.start()
    with app.state.sessionmaker() as db:
        flow = load(db, wizard.session_id)
        with statements_here() as statements:
            version = flow.newest_event_id()
    assert [s for s in statements if NEWEST in s.lower()], statements
    assert version == _newest_in_database(app, wizard.session_id)


def test_an_id_noted_in_an_earlier_transaction_is_not_used(
    app: FastAPI, client: TestClient, wizard: WizardBot
) -> None:
    """The same ``Session`` after its commit: another writer's event may have come since,
    so the version is read again, and is that event's."""
    wizard.start()
    with app.state.sessionmaker() as db:
        flow = load(db, wizard.session_id)
        mine = flow.log("note.added", payload={"text": "first"})
        assert flow.newest_event_id() == mine.id
        db.commit()
        # Another connection's event, committed after this session's transaction ended.
        with app.state.sessionmaker() as other:
            theirs = events.record(other, "note.added", source="wizard",
                                   session_id=wizard.session_id)  # fmt: skip
            other.commit()
            theirs_id = theirs.id
        with statements_here() as statements:
            version = load_by_token(db, wizard.token, lock=False).newest_event_id()
        assert [s for s in statements if NEWEST in s.lower()], statements
        assert version == theirs_id > mine.id


def test_an_event_deleted_in_the_transaction_makes_the_version_asked_again(
    app: FastAPI, client: TestClient, wizard: WizardBot
) -> None:
    wizard.start()
    with app.state.sessionmaker() as db:
        flow = load(db, wizard.session_id)
        before = flow.newest_event_id()
        added = flow.log("note.added", payload={"text": "gone again"})
        assert flow.newest_event_id() == added.id
        db.delete(added)
        db.flush()
        assert flow.newest_event_id() == before
        db.rollback()


def test_a_bulk_delete_of_events_makes_the_version_asked_again(
    app: FastAPI, client: TestClient, wizard: WizardBot
) -> None:
    """A ``delete(Event)`` statement (as withdrawal runs) passes no row through the mapper:
    the noted ids are forgotten and the version is what the database holds."""
    wizard.start()
    with app.state.sessionmaker() as db:
        flow = load(db, wizard.session_id)
        added = flow.log("note.added", payload={"text": "bulk-deleted"})
        assert flow.newest_event_id() == added.id
        db.execute(delete(Event).where(Event.id == added.id))
        with statements_here() as statements:
            version = flow.newest_event_id()
        assert [s for s in statements if NEWEST in s.lower()], statements
        assert version < added.id
        db.rollback()
