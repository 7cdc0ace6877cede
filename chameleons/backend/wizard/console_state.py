"""Everything the console shows, read from the database in one go (the page is rebuilt from
this after a reload, a reconnect or a live change, so nothing lives only in the browser).

The session itself is the session flow's snapshot; the console adds its timeline, the
interaction whose prompts are on the buttons, and the prompt groups that phrase the
pending suggestion.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from chameleons.backend.events import repository as events
from chameleons.backend.events.hub import LiveHub
from chameleons.backend.phone import devices
from chameleons.backend.sessions.flow import load as load_flow
from chameleons.backend.sessions.snapshot import committed, session_snapshot
from chameleons.backend.studies.specs import item_key
from chameleons.backend.wizard import layout
from chameleons.backend.wizard.catalogues import MissingCatalogueError, catalogue_for, is_loaded

TIMELINE_LIMIT = 5000


def console_state(
    db: Session,
    app_state: Any,
    session_id: int,
    base_url: str,
    new_events: list[dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """Raises the session flow's ``NotFoundError`` for an unknown session.

    With ``new_events`` (the events a live console was just sent, as published after their
    commit) the state carries only those (``events_delta``): the console adds them to the
    timeline it holds instead of the server reading and sending the whole timeline after
    every change (the largest cost of a busy server, docs/performance.md). Without, the
    whole timeline (first message, a reload, or a subscriber that fell behind)."""
    hub: LiveHub = app_state.live_hub
    phones = devices.phones(hub, session_id)
    snapshot = None
    if new_events:
        newest = max(int(event["id"]) for event in new_events)
        snapshot = committed(hub, session_id, newest, base_url, phones)
    if snapshot is None:
        snapshot = session_snapshot(load_flow(db, session_id, lock=False), base_url, phones)
    state = _around(app_state, snapshot)
    if new_events is None:
        timeline = events.for_session(db, session_id, limit=TIMELINE_LIMIT)
        state["events"] = [events.to_dict(event) for event in timeline]
        state["last_event_id"] = timeline[-1].id if timeline else 0
        return state
    return _with_delta(state, new_events)


def committed_console_state(
    app_state: Any, session_id: int, base_url: str, new_events: list[dict[str, Any]]
) -> dict[str, Any] | None:
    """``console_state`` after ``new_events`` without the database, when the live hub keeps
    the state their commit made (``committed``) and its prompts are in memory: the event
    loop builds it at once, without a trip through the thread pool (issue 34). None
    otherwise: the caller reads it in a thread (``console_state``)."""
    if not new_events:
        return None
    hub: LiveHub = app_state.live_hub
    newest = max(int(event["id"]) for event in new_events)
    snapshot = committed(hub, session_id, newest, base_url, devices.phones(hub, session_id))
    if snapshot is None or not _prompts_in_memory(app_state, snapshot):
        return None
    return _with_delta(_around(app_state, snapshot), new_events)


def _around(app_state: Any, snapshot: dict[str, Any]) -> dict[str, Any]:
    """The console's state around the session's snapshot, without its timeline."""
    position = prompt_position(snapshot)
    groups, missing = _suggestion_prompts(app_state, snapshot, position)
    return {
        "session": snapshot,
        "prompt_position": position,
        "suggestion_prompts": groups,
        # When none phrases the pending suggestion: which prompt the catalogue lacks.
        "suggestion_missing": missing,
        "worker": {"bridge": getattr(app_state, "bridge", None) is not None},
    }


def _with_delta(state: dict[str, Any], new_events: list[dict[str, Any]]) -> dict[str, Any]:
    state["events"] = sorted(new_events, key=lambda event: int(event["id"]))
    state["events_delta"] = True
    return state


def _pending(snapshot: dict[str, Any], position: int) -> tuple[Any, Any]:
    interaction = next(i for i in snapshot["interactions"] if i["position"] == position)
    pending = next((s for s in interaction["suggestions"] if s["accepted"] is None), None)
    return interaction, pending


def _prompts_in_memory(app_state: Any, snapshot: dict[str, Any]) -> bool:
    """The snapshot's suggestion prompts need no catalogue, or one already loaded."""
    interaction, pending = _pending(snapshot, prompt_position(snapshot))
    if pending is None or interaction["state"] != "negotiation":
        return True
    return is_loaded(app_state, interaction["actor"], snapshot.get("language"))


def prompt_position(snapshot: dict[str, Any]) -> int:
    """The interaction whose prompts the wizard needs: the current one, or the next once the
    current one is done (the session flow's own rule for "upcoming")."""
    current = snapshot["current_position"]
    state = next(i["state"] for i in snapshot["interactions"] if i["position"] == current)
    if state == "done" and current < snapshot["interaction_count"]:
        return int(current) + 1
    return int(current)


def _suggestion_prompts(
    app_state: Any, snapshot: dict[str, Any], position: int
) -> tuple[list[str], str | None]:
    """Groups phrasing the pending suggestion of ``position``, best first, and when there
    is none the sentence naming the prompt the catalogue lacks (the wizard must not word a
    suggestion himself)."""
    interaction, pending = _pending(snapshot, position)
    if pending is None or interaction["state"] != "negotiation":
        return [], None
    language = snapshot.get("language")
    try:
        catalogue = catalogue_for(app_state, interaction["actor"], language)
    except MissingCatalogueError as error:
        return [], str(error)
    ranking = interaction["current_ranking"] or interaction["initial_ranking"] or []
    task, item = interaction["task"], item_key(pending["item"])
    groups = layout.suggestion_groups(
        catalogue, task, item, pending["to_rank"], [item_key(i) for i in ranking]
    )
    if groups:
        return groups, None
    move = "down" if pending["to_rank"] > pending["from_rank"] else "up"
    return [], (
        f"No prompt phrases this suggestion: actor {interaction['actor']} has no 'move {move}' "
        f"suggestion prompt for {task}:{item}{f' in {language}' if language else ''} (the "
        f"demo names it {task}_{item}_move_{move}). Do not word it yourself: note it and "
        "add the prompt to the catalogue (prompts/README.md)."
    )
