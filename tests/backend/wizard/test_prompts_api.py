"""The console's prompt API: buttons for the interaction, play/stop logged with their outcome
(no worker runs here, so every play is "not sent: worker unreachable")."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from chameleons.prompts import load_catalogue
from tests.backend.wizard.conftest import api, to_negotiation
from tests.support.bots import ApiError, ParticipantBot, WizardBot

PROMPTS = Path(__file__).resolve().parents[3] / "prompts"


def sections_of(wizard: WizardBot) -> dict[str, list[dict[str, object]]]:
    data = wizard.staff.get(f"{api(wizard)}/prompts")
    return {section["id"]: section["buttons"] for section in data["sections"]}


def events_of(wizard: WizardBot, kind_prefix: str = "prompt.") -> list[dict[str, object]]:
    events = wizard.staff.get(f"/api/sessions/{wizard.session_id}/events")
    return [e for e in events if str(e["kind"]).startswith(kind_prefix)]


def test_item_buttons_follow_the_presented_order_with_digit_shortcuts(wizard: WizardBot) -> None:
    interaction = wizard.interaction(1)
    items = sections_of(wizard)["items"]
    describe = [b for b in items if b["stage"] == "item_description"]
    ask = [b for b in items if b["stage"] == "item_question"]
    assert [b["item"] for b in describe] == interaction["presented_order"]
    assert [b["item"] for b in ask] == interaction["presented_order"]
    assert [b["shortcut"]["label"] for b in describe] == ["1", "2", "3", "4", "5"]  # type: ignore[index]
    assert [b["shortcut"]["label"] for b in ask] == ["⇧1", "⇧2", "⇧3", "⇧4", "⇧5"]  # type: ignore[index]
    first = interaction["items"][0]["name"]
    assert describe[0]["label"] == f"Describe {first}"


def test_script_fits_the_robot_and_task_and_every_shortcut_is_unique(wizard: WizardBot) -> None:
    interaction = wizard.interaction(1)
    sections = sections_of(wizard)
    intro = [b for b in sections["script"] if b["stage"] == "intro"]
    assert [b["label"] for b in intro] == [f"Introduce ({interaction['robot_name']})"]
    scenario = [b for b in sections["script"] if b["stage"] == "scenario"]
    assert scenario
    assert all(interaction["task"] in str(b["group"]) for b in scenario)
    replies = {b["group"]: b["shortcut"]["label"] for b in sections["replies"]}  # type: ignore[index]
    assert replies["ack_yes"] == "Y"
    assert replies["ack_no"] == "N"
    assert replies["repeat"] == "R"
    keys = [
        (b["shortcut"]["code"], b["shortcut"]["shift"])  # type: ignore[index]
        for buttons in sections.values()
        for b in buttons
        if b["shortcut"]
    ]
    assert len(keys) == len(set(keys))
    reserved = {"KeyA", "KeyD", "KeyU", "KeyM", "Comma", "Period", "Space", "Slash"}
    assert not reserved & {code for code, _shift in keys}


def test_suggestion_prompts_are_only_about_the_items_shown(wizard: WizardBot) -> None:
    shown = set(wizard.interaction(1)["presented_order"])
    suggestions = sections_of(wizard)["suggestions"]
    assert suggestions
    assert all(b["item"] in shown for b in suggestions)
    assert all(b["other_item"] is None or b["other_item"] in shown for b in suggestions)


def test_a_play_without_a_worker_is_logged_as_not_sent(wizard: WizardBot) -> None:
    result = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_yes"})
    assert result["sent"] is False
    assert result["reason"] == "no_worker"
    assert "worker unreachable" in result["detail"]
    assert result["group"] == "ack_yes"
    assert result["text"]
    played, not_sent = events_of(wizard)
    assert played["kind"] == "prompt.played"
    assert played["source"] == "wizard"
    assert played["payload"]["prompt_id"] == result["prompt_id"]  # type: ignore[index]
    assert played["payload"]["position"] == 1  # type: ignore[index]
    assert not_sent["kind"] == "prompt.not_sent"
    assert not_sent["payload"]["play_event_id"] == played["id"]  # type: ignore[index]


def test_variants_are_random_but_never_the_same_twice_in_a_row(wizard: WizardBot) -> None:
    catalogue = load_catalogue(PROMPTS / wizard.interaction(1)["actor"])
    variants = {p.id for p in catalogue.group("ack_okay").prompts}
    assert len(variants) > 1
    played = [
        wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_okay"})["prompt_id"]
        for _ in range(12)
    ]
    assert all(a != b for a, b in itertools.pairwise(played))
    assert set(played) <= variants
    assert len(set(played)) >= 2


def test_stop_is_logged_with_the_prompt_it_stopped(wizard: WizardBot) -> None:
    played = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_hmm"})
    result = wizard.staff.post(f"{api(wizard)}/prompts/stop")
    assert result["sent"] is False
    assert result["reason"] == "no_worker"
    stopped = events_of(wizard)[-1]
    assert stopped["kind"] == "prompt.stopped"
    assert stopped["payload"]["play_event_id"] == played["event_id"]  # type: ignore[index]


def test_unknown_group_and_unknown_session_are_404(wizard: WizardBot) -> None:
    with pytest.raises(ApiError) as caught:
        wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "no_such_group"})
    assert caught.value.status == 404
    assert "no prompt group" in str(caught.value.detail)
    with pytest.raises(ApiError) as caught:
        wizard.staff.post("/api/wizard/sessions/999999/prompts/play", {"group": "ack_yes"})
    assert caught.value.status == 404
    assert events_of(wizard) == []


def test_play_needs_login_and_the_csrf_header(client: TestClient, wizard: WizardBot) -> None:
    path = f"{api(wizard)}/prompts/play"
    assert client.post(path, json={"group": "ack_yes"}).status_code == 403
    client.cookies.clear()
    assert client.post(path, json={"group": "ack_yes"}).status_code in (401, 403)
    assert client.get(f"{api(wizard)}/console").status_code == 401


def test_console_state_carries_the_snapshot_timeline_and_suggestion_prompts(
    wizard: WizardBot, phone: ParticipantBot
) -> None:
    ranking = to_negotiation(wizard, phone)
    state = wizard.staff.get(f"{api(wizard)}/console")
    assert state["session"]["id"] == wizard.session_id
    assert state["prompt_position"] == 1
    assert state["worker"] == {"bridge": False}
    kinds = [e["kind"] for e in state["events"]]
    assert kinds[-1] == "suggestion.proposed"
    assert "ranking.submitted" in kinds
    assert state["last_event_id"] == state["events"][-1]["id"]
    pending = state["session"]["interactions"][0]["suggestions"][0]
    interaction = wizard.interaction(1)
    catalogue = load_catalogue(PROMPTS / interaction["actor"])
    target = ranking[pending["to_rank"] - 1]
    expected = catalogue.suggestion_prompts(
        interaction["task"], pending["item"], pending["to_rank"], target
    )
    assert state["suggestion_prompts"] == [g.name for g in expected]
    assert state["suggestion_prompts"], "the demo catalogue phrases every move"
    first = catalogue.group(state["suggestion_prompts"][0]).prompts[0]
    assert first.item == pending["item"]
    assert first.other_item == target


def test_prompts_follow_the_next_interaction_once_one_is_done(
    wizard: WizardBot, phone: ParticipantBot
) -> None:
    to_negotiation(wizard, phone)
    wizard.negotiate(1, lambda _s: True)
    wizard.advance(1, "questionnaire")
    import random

    phone.answer_questionnaires(1, random.Random(3))
    assert wizard.refresh()["interactions"][0]["state"] == "done"
    state = wizard.staff.get(f"{api(wizard)}/console")
    assert state["prompt_position"] == 2
    data = wizard.staff.get(f"{api(wizard)}/prompts")
    assert data["position"] == 2
    assert data["actor"] == wizard.interaction(2)["actor"]
    played = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_yes"})
    assert played["prompt_id"]
    assert events_of(wizard)[-2]["payload"]["position"] == 2  # type: ignore[index]
