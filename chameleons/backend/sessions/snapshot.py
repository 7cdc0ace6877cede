"""The wizard's view of a session as JSON: everything the console shows, in one object."""

from __future__ import annotations

from typing import Any

from chameleons.backend.events import repository as events
from chameleons.backend.events.hub import LiveHub, session_channel
from chameleons.backend.models import Interaction, Suggestion
from chameleons.backend.sessions.answers import (
    FINAL_POSITION,
    answered_by_position,
    questionnaires_for,
)
from chameleons.backend.sessions.flow import Flow, allowed_actions, undo_deadline
from chameleons.backend.sessions.pausing import paused_view
from chameleons.backend.sessions.states import STEPS, allowed_sentence
from chameleons.backend.studies.specs import item_key
from chameleons.experiment.model import Condition
from chameleons.worker.behaviours.copy_params import in_words

CONSOLE_VIEW = "console"


def phone_presence_key(session_id: int) -> str:
    return f"phone:{session_id}"


_time = events.iso


def session_snapshot(flow: Flow, base_url: str, phones: list[dict[str, Any]]) -> dict[str, Any]:
    """``phones``: the phones on the link now, oldest first (``phone.devices.phones``)."""
    session = flow.session
    actions = allowed_actions(flow)
    # One query each for every interaction's suggestions and answers (not one per part);
    # settled interactions' suggestions are kept (``_SETTLED``) and not read again.
    settled = _settled_parts(flow)
    suggestions = flow.suggestions_by_interaction(known=settled.keys())
    shown = {i.id: settled.get(i.id) or _suggestion_parts(flow, i, suggestions[i.id])
             for i in flow.interactions}  # fmt: skip
    done = answered_by_position(flow)
    return {
        "id": session.id,
        "study_id": session.study_id,
        "config_hash": flow.study.config_hash,
        "state": session.state,
        "current_position": session.current_position,
        "interaction_count": len(flow.interactions),
        "booth": session.booth,
        "is_rehearsal": session.is_rehearsal,
        "language": session.language,
        "languages": list(flow.spec.languages),
        "created_at": _time(session.created_at),
        "started_at": _time(session.started_at),
        "completed_at": _time(session.completed_at),
        "paused": paused_view(flow),
        "pause_count": session.pause_count,
        "paused_seconds": session.paused_seconds,
        "participant": {"id": flow.participant.id, "code": flow.participant.code},
        "phone": {
            **_links(base_url, session.phone_token),
            "short_code": session.short_code,
            "qr_svg": f"/api/sessions/{session.id}/phone-qr.svg",
            **_phones(phones),
        },
        "conditions": list(flow.spec.condition_ids),
        "suggestions_per_interaction": flow.spec.suggestions_per_interaction,
        "condition_details": [_condition(c) for c in flow.spec.conditions],
        "interactions": [
            _interaction(flow, i, shown[i.id], done.get(i.position, set()))
            for i in flow.interactions
        ],
        "final_questionnaire": _progress(flow, FINAL_POSITION, done.get(FINAL_POSITION, set())),
        "allowed": actions,
        "allowed_sentence": allowed_sentence(actions),
        "version": flow.newest_event_id(),
    }


def _links(base_url: str, phone_token: str) -> dict[str, str]:
    return {"url": f"{base_url}/p/{phone_token}", "join_url": f"{base_url}/join"}


def _phones(phones: list[dict[str, Any]]) -> dict[str, Any]:
    return {"connected": bool(phones), "connections": len(phones), "devices": phones}


def retain(flow: Flow, snapshot: dict[str, Any]) -> None:
    """Once the transaction that made ``snapshot`` commits, the live hub keeps it as the
    session's latest state: a console woken by the same commit's events takes it from
    there (``committed``) instead of loading the session again."""
    value = {"version": snapshot["version"], "token": flow.session.phone_token,
             "snapshot": snapshot}  # fmt: skip
    events.retain_after_commit(flow.db, session_channel(snapshot["id"]), CONSOLE_VIEW, value)


def committed(
    hub: LiveHub, session_id: int, version: int, base_url: str, phones: list[dict[str, Any]]
) -> dict[str, Any] | None:
    """The retained snapshot of ``session_id`` if it is the state as of event ``version``
    (the newest event a live reader was sent); with the phone's links for ``base_url`` (the
    reader's address, not necessarily that of the request that made it) and ``phones`` as
    they are now. None otherwise: the caller loads the session."""
    found = hub.retained(session_channel(session_id), CONSOLE_VIEW)
    if found is None or found["version"] != version:
        return None
    snapshot: dict[str, Any] = found["snapshot"]
    # A copy where it changes: the retained one is shared between threads.
    phone = {**snapshot["phone"], **_links(base_url, found["token"]), **_phones(phones)}
    return {**snapshot, "phone": phone}


def _condition(condition: Condition) -> dict[str, Any]:
    """What the wizard needs to tell the conditions apart: label, behaviour, parameters."""
    return {
        "id": condition.id,
        "label": condition.label,
        "behaviour": condition.behaviour,
        "summary": behaviour_summary(condition),
    }


def behaviour_summary(condition: Condition) -> str:
    """A few words on what the robot does, e.g. "copies head, 4 s late, same side" (every
    copy parameter in words, chameleons.worker.behaviours.copy_params) or "natural: clip"."""
    params = condition.params
    if condition.behaviour == "copy":
        return in_words(params)
    if condition.behaviour == "natural":
        return f"natural: {params.get('source', 'clip')}"
    shown = ", ".join(f"{k} {v}" for k, v in sorted(params.items()))
    return condition.behaviour + (f" ({shown})" if shown else "")


def _interaction(
    flow: Flow, interaction: Interaction, suggestions: SuggestionParts, done: set[str]
) -> dict[str, Any]:
    task_name, items, expert_order = _task_parts(flow, interaction)
    return {
        "position": interaction.position,
        "state": interaction.state,
        "planned_condition": interaction.planned_condition,
        "condition": interaction.condition,
        "deviates_from_plan": interaction.condition != interaction.planned_condition,
        "natural": (
            {"source": interaction.natural_source, "recording": interaction.natural_recording}
            if interaction.natural_source
            else None
        ),
        "actor": interaction.actor,
        "robot_name": interaction.robot_name,
        "face": interaction.face,
        "task": interaction.task,
        "task_name": task_name,
        "item_set": interaction.item_set,
        "scenario": f"{interaction.task}-{interaction.item_set}",
        "items": items,
        "presented_order": list(interaction.presented_order),
        "expert_order": expert_order,
        "initial_ranking": interaction.initial_ranking,
        "current_ranking": interaction.current_ranking,
        "final_ranking": interaction.final_ranking,
        "started_at": _time(interaction.started_at),
        "ended_at": _time(interaction.ended_at),
        "suggestions": list(suggestions[0]),
        "accepted": suggestions[1],
        "questionnaires": _progress(flow, interaction.position, done),
    }


# An interaction's task name, items and expert order follow from the study's config and
# the presented order alone, which never change: built once per (config, task, order)
# instead of at every snapshot (issue 34). Shared by the snapshots, which are read only.
TaskParts = tuple[str, list[dict[str, Any]], list[str]]
_TASK_PARTS: dict[tuple[str, str, tuple[str, ...]], TaskParts] = {}
_TASK_PARTS_MAX = 4096  # a server's sessions x interactions; emptied when full


def _task_parts(flow: Flow, interaction: Interaction) -> TaskParts:
    presented = tuple(map(str, interaction.presented_order))
    key = (flow.study.config_hash, interaction.task, presented)
    found = _TASK_PARTS.get(key)
    if found is None:
        task = flow.spec.task(interaction.task)
        items = [{"id": item_id, "name": item.name, "description": item.description,
                  "expert_rank": item.expert_rank}
                 for item_id, item in ((i, task.item(item_key(i))) for i in presented)]  # fmt: skip
        found = (task.name, items, flow.spec.expert_order(interaction.task, list(presented)))
        if len(_TASK_PARTS) >= _TASK_PARTS_MAX:
            _TASK_PARTS.clear()
        _TASK_PARTS[key] = found
    return found


# An interaction's suggestions are final once it is past its negotiation (they are
# proposed, decided and undone only in it: sessions.negotiation). Their parts are kept per
# (session link, interaction) once that state is committed, so a snapshot reads only the
# suggestions of an interaction still in negotiation (issue 34). Kept after the commit, not
# before: a rolled-back advance to the questionnaire leaves an undo possible. The link is
# the key because ids may be reused after a withdrawal deletes a session; links are not.
SuggestionParts = tuple[list[dict[str, Any]], int]  # the suggestions shown, how many accepted
SETTLED_STEPS = frozenset(STEPS[STEPS.index("negotiation") + 1 :])
_SETTLED: dict[tuple[str, int], SuggestionParts] = {}
_SETTLED_MAX = 4096  # a server's sessions x interactions; emptied when full
NO_SUGGESTIONS: SuggestionParts = ([], 0)  # shared: ``_interaction`` copies the list


def _settled_parts(flow: Flow) -> dict[int, SuggestionParts]:
    token = flow.session.phone_token
    found = {}
    for interaction in flow.interactions:
        if interaction.state in SETTLED_STEPS:
            parts = _SETTLED.get((token, interaction.id))
            if parts is not None:
                found[interaction.id] = parts
    return found


def _suggestion_parts(
    flow: Flow, interaction: Interaction, suggestions: list[Suggestion]
) -> SuggestionParts:
    if not suggestions and interaction.state not in SETTLED_STEPS:
        return NO_SUGGESTIONS  # before its negotiation (or at its very start)
    parts = ([_suggestion(flow, interaction, s) for s in suggestions],
             sum(1 for s in suggestions if s.accepted))  # fmt: skip
    if interaction.state in SETTLED_STEPS:
        key = (flow.session.phone_token, interaction.id)
        events.keep_once_committed(flow.db, _SETTLED, key, parts, _SETTLED_MAX)
    return parts


def _suggestion(flow: Flow, interaction: Interaction, suggestion: Suggestion) -> dict[str, Any]:
    deadline = undo_deadline(suggestion)
    item = flow.spec.task(interaction.task).item(item_key(suggestion.item))
    return {
        "index": suggestion.index,
        "item": suggestion.item,
        "item_name": item.name,
        "from_rank": suggestion.from_rank,
        "to_rank": suggestion.to_rank,
        "kind": suggestion.kind,
        "accepted": suggestion.accepted,
        "proposed_at": _time(suggestion.proposed_at),
        "decided_at": _time(suggestion.decided_at),
        "undo_until": _time(deadline),
    }


def _progress(flow: Flow, position: int, done: set[str]) -> dict[str, Any]:
    required = [q.id for q in questionnaires_for(flow, position)]
    return {"required": required, "answered": [q for q in required if q in done]}
