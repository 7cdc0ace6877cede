"""Idempotent participant submissions.

The stored event with the submission's client id is the receipt: a resubmission (the
phone retrying after a lost response, a reload, a reconnect) gets that receipt back and
nothing is stored twice. Two copies racing each other are serialised by the session row
lock (PostgreSQL) or the single writer (SQLite).

The client id is looked up only when storing fails, not before every submission (one
statement less on every first submission, issue 34): a resubmission either fails its
checks (the ranking is saved already, the page is no longer open, ...) or, where storing
again is allowed, breaks the unique (session, client id) constraint of the event it logs.
Either way the change is rolled back and the stored event's receipt is the answer; a
failure with no stored event is the participant's error, raised as it was.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from chameleons.backend.events import repository as events
from chameleons.backend.models import Event
from chameleons.backend.phone.retained import retained_state
from chameleons.backend.sessions.flow import Flow, load_by_token
from chameleons.backend.sessions.snapshot import retain, session_snapshot
from chameleons.backend.studies.errors import FlowError

Receipt = dict[str, Any]


def submit(db: Session, token: str, client_id: str, store: Callable[[Flow], Event]) -> Receipt:
    flow = load_by_token(db, token)
    try:
        event = store(flow)
    except (FlowError, IntegrityError):
        # Whatever the failed store changed goes before the look-up (which would flush it).
        db.rollback()
        flow = load_by_token(db, token)
        stored = events.find_by_client_id(db, flow.session.id, client_id)
        if stored is None:
            raise
        return _receipt(flow, stored, duplicate=True)
    return _receipt(flow, event, duplicate=False)


def _receipt(flow: Flow, event: Event, duplicate: bool) -> Receipt:
    # The console's state as this change leaves it, kept for the console woken by the
    # change (its links and phones are the reader's own: sessions.snapshot.committed).
    snapshot = session_snapshot(flow, "", [])
    retain(flow, snapshot)
    return {
        "saved": True,
        "duplicate": duplicate,
        "client_id": event.client_id,
        "kind": event.kind,
        "stored": event.payload,
        "saved_at": events.iso(event.server_time),
        "state": retained_state(flow, snapshot["version"]),  # the phone socket's next view
    }
