"""The phone's view as the change that made it committed it, kept for the phone's socket.

Every change of a session wakes the phone's socket, which sent the phone its view read
afresh from the database (a session load per change and phone). The changes a phone
follows make that view anyway: a phone's own submission answers with it, and a wizard's
action answers with the session's snapshot, beside which the view costs no statement.
Once that transaction commits, the live hub keeps the view (as the console's,
``sessions.snapshot.retain``), and a socket woken by that commit's events sends it when
its version (the session's newest event id when it was made) is the newest event the
socket was just sent. Another server process's views come through the fan-out
(``events.pg_fanout``) before their events and are taken the same way. Anything else (a
change that made no view, views too large for a NOTIFY) is read from the database as before.
"""

from __future__ import annotations

from chameleons.backend.events import repository as events
from chameleons.backend.events.hub import LiveHub, Message, session_channel
from chameleons.backend.phone.view import PhoneState, phone_state
from chameleons.backend.sessions.flow import Flow

PHONE_VIEW = "phone"


def retained_state(flow: Flow, version: int | None = None) -> PhoneState:
    """``phone_state(flow)``, kept for the phone's socket once the transaction commits
    (``version``: the session's newest event id, when the caller has it already)."""
    state = phone_state(flow, version)
    value = {"version": state["version"], "state": state}
    events.retain_after_commit(flow.db, session_channel(flow.session.id), PHONE_VIEW, value)
    return state


def committed(hub: LiveHub, session_id: int, messages: list[Message]) -> PhoneState | None:
    """The kept view when ``messages`` (a batch the socket was sent) are all events and the
    newest of them is the kept view's version; None otherwise (the caller reads it)."""
    if not messages or any(message.get("type") != "event" for message in messages):
        return None
    newest = max(int(message["event"]["id"]) for message in messages)
    found = hub.retained(session_channel(session_id), PHONE_VIEW)
    if found is None or found["version"] != newest:
        return None
    state: PhoneState = found["state"]
    return state
