"""Negotiation: three policy suggestions decided in order, accepted ones move the ranking,
the last decision can be undone for a few seconds; condition switches and notes are logged."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

from sqlalchemy import Engine, update

from chameleons.backend.models import Suggestion
from chameleons.experiment.suggestions import Suggestion as Move
from chameleons.experiment.suggestions import apply_suggestion
from tests.backend.sessions.conftest import refused, to_negotiation
from tests.support.bots import ParticipantBot, StaffApi, WizardBot


def _move(suggestion: dict[str, object]) -> Move:
    return Move(
        str(suggestion["item"]),
        int(suggestion["from_rank"]),  # type: ignore[call-overload]
        int(suggestion["to_rank"]),  # type: ignore[call-overload]
        "optimal",
    )


def test_accepted_suggestions_move_the_ranking_and_are_stored(
    wizard: WizardBot, phone: ParticipantBot
) -> None:
    initial = to_negotiation(wizard, phone)
    interaction = wizard.interaction(1)
    assert interaction["initial_ranking"] == initial
    assert [s["index"] for s in interaction["suggestions"]] == [1]
    expected = list(initial)
    for accepted in (True, False, True):
        pending = wizard.interaction(1)["suggestions"][-1]
        assert pending["accepted"] is None
        assert pending["to_rank"] < pending["from_rank"]
        assert pending["kind"] in ("optimal", "random")
        if accepted:
            expected = apply_suggestion(expected, _move(pending))
        wizard.decide(1, pending["index"], accepted)
        assert wizard.interaction(1)["current_ranking"] == expected
    assert phone.state()["ranking"] == expected
    snapshot = wizard.advance(1, "questionnaire")
    interaction = snapshot["interactions"][0]
    assert [s["accepted"] for s in interaction["suggestions"]] == [True, False, True]
    assert interaction["accepted"] == 2
    assert interaction["initial_ranking"] == initial
    assert interaction["final_ranking"] == expected


def test_decisions_go_in_order_and_only_once(wizard: WizardBot, phone: ParticipantBot) -> None:
    to_negotiation(wizard, phone)
    assert "has not been proposed yet" in refused(lambda: wizard.decide(1, 2, True), 409)
    assert "no suggestion 4" in refused(lambda: wizard.decide(1, 4, True), 422)
    wizard.decide(1, 1, False)
    message = refused(lambda: wizard.decide(1, 1, True), 409)
    assert message.startswith("Suggestion 1 of interaction 1 is already declined.")
    assert "accept or decline suggestion 2 of interaction 1" in message
    assert "undo the decision on suggestion 1" in message
    assert [s["accepted"] for s in wizard.refresh()["interactions"][0]["suggestions"]] == [
        False,
        None,
    ]


def test_deciding_outside_negotiation_is_refused(wizard: WizardBot) -> None:
    wizard.start()
    wizard.advance(1, "discussion")
    message = refused(lambda: wizard.decide(1, 1, True), 409)
    assert message.startswith("Cannot decide a suggestion: interaction 1 is in discussion")


def test_undo_restores_the_ranking_and_the_same_suggestion_follows(
    wizard: WizardBot, phone: ParticipantBot
) -> None:
    initial = to_negotiation(wizard, phone)
    first = wizard.interaction(1)["suggestions"][0]
    wizard.decide(1, 1, True)
    second = wizard.interaction(1)["suggestions"][1]
    assert wizard.interaction(1)["current_ranking"] != initial
    assert "undo the decision on suggestion 1" in wizard.snapshot["allowed_sentence"]
    wizard.undo(1, 1)
    interaction = wizard.interaction(1)
    assert interaction["current_ranking"] == initial
    assert [s["accepted"] for s in interaction["suggestions"]] == [None]
    assert interaction["suggestions"][0]["item"] == first["item"]
    wizard.decide(1, 1, True)
    again = wizard.interaction(1)["suggestions"][1]
    assert {k: again[k] for k in ("item", "from_rank", "to_rank", "kind")} == {
        k: second[k] for k in ("item", "from_rank", "to_rank", "kind")
    }
    events = wizard.staff.get(f"/api/sessions/{wizard.session_id}/events")
    undone = [e for e in events if e["kind"] == "suggestion.undone"]
    assert len(undone) == 1
    assert undone[0]["payload"]["was_accepted"] is True
    assert undone[0]["payload"]["withdrawn_proposals"] == [2]


def test_undo_only_the_last_decision_and_only_in_time(
    wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    to_negotiation(wizard, phone)
    assert "that is nothing yet" in refused(lambda: wizard.undo(1, 1), 409)
    wizard.decide(1, 1, True)
    wizard.decide(1, 2, False)
    message = refused(lambda: wizard.undo(1, 1), 409)
    assert message.startswith("Only the last decision can be undone; in interaction 1 that is")
    past = datetime.now(UTC) - timedelta(seconds=60)
    with engine.begin() as connection:
        connection.execute(update(Suggestion).where(Suggestion.index == 2).values(decided_at=past))
    assert "too late" in refused(lambda: wizard.undo(1, 2), 409)
    assert "undo" not in wizard.refresh()["allowed_sentence"]


def test_condition_switch_records_the_actual_condition_and_a_deviation(
    wizard: WizardBot, pi: StaffApi
) -> None:
    planned = wizard.interaction(1)["planned_condition"]
    other = next(c for c in wizard.snapshot["conditions"] if c != planned)
    assert "not a condition" in refused(lambda: wizard.switch_condition("wobble"), 422)
    wizard.switch_condition(planned)  # already running that one: nothing to log
    wizard.start()
    snapshot = wizard.switch_condition(other)
    assert snapshot["interactions"][0]["condition"] == other
    assert snapshot["interactions"][0]["planned_condition"] == planned
    assert snapshot["interactions"][0]["deviates_from_plan"] is True
    wizard.switch_condition(planned, position=1)
    events = pi.get(f"/api/sessions/{wizard.session_id}/events")
    switches = [e["payload"] for e in events if e["kind"] == "condition.switched"]
    assert [(s["from"], s["to"]) for s in switches] == [(planned, other), (other, planned)]
    deviations = [e["payload"] for e in events if e["kind"] == "plan.deviation"]
    assert deviations == [
        {"position": 1, "from": planned, "to": other, "planned": planned, "field": "condition"}
    ]


def test_wizard_notes_go_to_the_timeline_with_worker_time(wizard: WizardBot) -> None:
    wizard.start()
    path = f"/api/sessions/{wizard.session_id}/events"
    body = {"kind": "prompt.played", "payload": {"prompt": "intro-1"}, "worker_time": 12.5}
    event = wizard.staff.post(path, {**body, "position": 1})
    assert event["kind"] == "wizard.prompt.played"
    assert event["worker_time"] == 12.5
    assert event["payload"] == {"prompt": "intro-1"}
    assert "pattern" in str(refused(lambda: wizard.staff.post(path, {"kind": "Bad Kind"}), 422))
    after = wizard.staff.get(f"{path}?after={event['id'] - 1}")
    assert [e["id"] for e in after] == [event["id"]]
