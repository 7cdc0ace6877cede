"""The phone's socket sends the view the change it was woken by committed (the phone's own
submission, a wizard's action) instead of loading the session again; a batch that is not
only events, or whose newest event is not the kept view's, is read from the database
(chameleons.backend.phone.retained)."""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.phone.retained import committed
from tests.backend.wizard.test_retained_state import newest_event, statements_here
from tests.support.bots import ParticipantBot, WizardBot


def _batch(*events: dict[str, Any]) -> list[dict[str, Any]]:
    return [{"type": "event", "event": event} for event in events]


def test_the_view_a_wizard_action_committed_is_the_phones_next_view(
    app: FastAPI, client: TestClient, wizard: WizardBot, phone: ParticipantBot
) -> None:
    wizard.start()
    before = newest_event(app, wizard.session_id)
    answered = wizard.advance(1, "discussion")
    advanced = newest_event(app, wizard.session_id)
    assert advanced["id"] == answered["version"] > before["id"]
    with statements_here() as statements:
        kept = committed(app.state.live_hub, wizard.session_id, _batch(before, advanced))
    assert statements == []  # nothing loaded
    assert kept is not None
    assert kept == phone.state()  # what a fresh read gives
    assert (kept["view"], kept["version"]) == ("listen", advanced["id"])


def test_the_view_a_submission_committed_is_the_phones_next_view(
    app: FastAPI, client: TestClient, wizard: WizardBot, phone: ParticipantBot
) -> None:
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    ranking = list(reversed(wizard.interaction(1)["presented_order"]))
    receipt = phone.submit_ranking(1, ranking)
    submitted = newest_event(app, wizard.session_id)
    kept = committed(app.state.live_hub, wizard.session_id, _batch(submitted))
    assert kept is not None
    assert kept == receipt["state"] == phone.state()
    assert (kept["view"], kept["ranking"]) == ("ranked", ranking)


def test_a_batch_the_kept_view_does_not_end_is_read_again(
    app: FastAPI, client: TestClient, wizard: WizardBot, phone: ParticipantBot
) -> None:
    wizard.start()
    started = newest_event(app, wizard.session_id)
    wizard.advance(1, "discussion")
    advanced = newest_event(app, wizard.session_id)
    hub = app.state.live_hub
    assert committed(hub, wizard.session_id, _batch(advanced)) is not None
    # An older event: the kept view is of a later change.
    assert committed(hub, wizard.session_id, _batch(started)) is None
    # Anything but events (a presence notice) may change what the phone must be sent.
    presence = [*_batch(advanced), {"type": "presence", "kind": "phone.connected"}]
    assert committed(hub, wizard.session_id, presence) is None
    assert committed(hub, wizard.session_id, []) is None
    # A later change that kept no phone view (a wizard's note) replaces the kept views.
    wizard.staff.post(f"/api/sessions/{wizard.session_id}/notes", {"text": "laughed"})
    noted = newest_event(app, wizard.session_id)
    assert noted["id"] > advanced["id"]
    assert committed(hub, wizard.session_id, _batch(noted)) is None


def test_the_phone_socket_sends_the_kept_view(
    client: TestClient, wizard: WizardBot, phone: ParticipantBot
) -> None:
    with client.websocket_connect(f"/ws/p/{wizard.token}") as socket:
        assert socket.receive_json()["state"]["view"] == "consent"
        wizard.start()
        wizard.advance(1, "discussion")
        while (message := socket.receive_json())["state"]["view"] != "listen":
            pass
        assert message["state"] == phone.state()
