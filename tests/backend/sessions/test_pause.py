"""Pausing and resuming a session through the real HTTP API (both databases): the refusals
while paused, what the phone sees, the totals on the session and the export."""

from __future__ import annotations

import json
import random

from fastapi.testclient import TestClient

from chameleons.backend.sessions.pausing import PHONE_PAUSED
from tests.backend.sessions.conftest import refused
from tests.backend.sessions.test_end_early import export
from tests.support.bots import ParticipantBot, StaffApi, WizardBot


def pause(pi: StaffApi, wizard: WizardBot, reason: str, note: str = "") -> dict[str, object]:
    result: dict[str, object] = pi.post(
        f"/api/sessions/{wizard.session_id}/pause", {"reason": reason, "note": note}
    )
    return result


def resume(pi: StaffApi, wizard: WizardBot) -> dict[str, object]:
    result: dict[str, object] = pi.post(f"/api/sessions/{wizard.session_id}/resume", {})
    return result


def test_pause_refusals_change_nothing(pi: StaffApi, wizard: WizardBot) -> None:
    message = refused(lambda: pause(pi, wizard, "participant_break"), 409)
    assert "Only a session that is running can be paused (it is pending)." in message
    assert "Allowed now:" in message
    wizard.start()
    for body, text in [
        ({"reason": "bored"}, "is not a reason to pause a session"),
        ({"reason": "other", "note": "  "}, "Say in a few words why the session pauses"),
    ]:
        assert text in refused(lambda b=body: pi.post(  # type: ignore[misc]
            f"/api/sessions/{wizard.session_id}/pause", b), 422)  # fmt: skip
    assert wizard.refresh()["paused"] is None
    assert "The session is not paused." in refused(lambda: resume(pi, wizard), 409)


def test_nothing_moves_on_while_paused(
    client: TestClient, pi: StaffApi, study_id: int, wizard: WizardBot, phone: ParticipantBot
) -> None:
    phone.prepare(random.Random(1))
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    ranking = [item["id"] for item in phone.state()["items"]]

    snapshot = pause(pi, wizard, "other", "fire alarm test")
    paused = snapshot["paused"]
    assert isinstance(paused, dict)
    assert (paused["reason"], paused["note"], paused["position"]) == ("other", "fire alarm test", 1)
    assert snapshot["allowed_sentence"] == "Allowed now: resume the paused session."
    assert phone.state()["view"] == "paused"
    # The phone's answer is refused with a sentence (the page keeps it and sends it later).
    assert refused(lambda: phone.submit_ranking(1, ranking), 409) == PHONE_PAUSED
    advance = refused(lambda: wizard.advance(1, "negotiation"), 409)
    assert advance.startswith("The session is paused: moving interaction 1 to negotiation")
    assert "already paused" in refused(lambda: pause(pi, wizard, "participant_break"), 409)
    play = refused(
        lambda: pi.post(f"/api/wizard/sessions/{wizard.session_id}/prompts/play", {"group": "x"}),
        409,
    )
    assert "paused: prompts are off" in play
    # A note is still fine while paused.
    pi.post(f"/api/sessions/{wizard.session_id}/notes", {"text": "waiting for the alarm"})

    resumed = resume(pi, wizard)
    assert resumed["paused"] is None
    assert resumed["pause_count"] == 1
    assert phone.state()["view"] == "ranking"
    phone.submit_ranking(1, ranking)
    wizard.advance(1, "negotiation")

    events = pi.get(f"/api/sessions/{wizard.session_id}/events")
    kinds = [e["kind"] for e in events]
    assert kinds.index("session.paused") < kinds.index("session.resumed")
    resumed_event = next(e for e in events if e["kind"] == "session.resumed")
    assert resumed_event["payload"]["reason"] == "other"
    assert resumed_event["payload"]["paused_s"] == resumed["paused_seconds"]
    assert isinstance(resumed["paused_seconds"], float)
    assert resumed["paused_seconds"] >= 0

    page = client.get(f"/pi/sessions/{wizard.session_id}").text
    assert "paused 1 time, " in page  # the PI's session page
    assert "session.resumed" in page

    tables = export(client, study_id)
    row = next(r for r in tables["participants"] if r["session"] == str(wizard.session_id))
    assert row["pause_count"] == "1"
    assert float(row["paused_s"]) == resumed["paused_seconds"]
    exported = [e for e in tables["events"] if e["kind"] in ("session.paused", "session.resumed")]
    assert [e["kind"] for e in exported] == ["session.paused", "session.resumed"]
    assert json.loads(exported[0]["payload"])["note"] == "fire alarm test"


def test_ending_a_paused_session_closes_the_pause(pi: StaffApi, wizard: WizardBot) -> None:
    wizard.start()
    pause(pi, wizard, "technical_failure")
    ended = wizard.end("technical_failure", "robot did not come back")
    assert ended["state"] == "ended"
    assert ended["paused"] is None
    assert ended["pause_count"] == 1
    events = pi.get(f"/api/sessions/{wizard.session_id}/events")
    end = next(e for e in events if e["kind"] == "session.ended_early")
    assert end["payload"]["paused_s"] == ended["paused_seconds"]
