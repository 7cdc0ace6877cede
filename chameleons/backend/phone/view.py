"""What the participant's phone may know about its session, built field by field.

This is the only source of data sent to the phone (page, JSON, WebSocket). It is built by
whitelisting: robot name, items (id and name), rankings and the questionnaire wording.
Condition, actor, face and plan details never enter it.
"""

from __future__ import annotations

from typing import Any

from chameleons.backend.events import repository as events
from chameleons.backend.models import Interaction
from chameleons.backend.sessions.answers import FINAL_POSITION, answered, questionnaires_for
from chameleons.backend.sessions.flow import Flow
from chameleons.backend.studies.specs import item_key
from chameleons.experiment.model import Questionnaire

PhoneState = dict[str, Any]


def phone_state(flow: Flow) -> PhoneState:
    state = _view(flow)
    state["version"] = events.last_id(flow.db, flow.session.id)
    state["of"] = len(flow.interactions)
    return state


def _view(flow: Flow) -> PhoneState:
    session = flow.session
    if session.state in ("complete", "ended"):
        return {"view": "ended"}
    if session.state == "pending":
        return {"view": "welcome"}
    if session.state == "final_questionnaire":
        return _questionnaire(flow, FINAL_POSITION, robot_name=None)
    current = flow.current
    base = {"position": current.position, "robot_name": current.robot_name}
    step = current.state
    if step in ("pending", "done"):
        return {"view": "waiting", "position": current.position, "after": step == "done"}
    if step == "discussion":
        return {**base, "view": "listen"}
    if step == "ranking" and current.initial_ranking is None:
        return {**base, "view": "ranking", **_task(flow, current)}
    if step in ("ranking", "negotiation"):
        ranking = current.current_ranking or current.initial_ranking or []
        return {**base, "view": "ranked", **_task(flow, current), "ranking": list(ranking)}
    return _questionnaire(flow, current.position, robot_name=current.robot_name)


def _task(flow: Flow, interaction: Interaction) -> PhoneState:
    task = flow.spec.task(interaction.task)
    return {
        "task_name": task.name,
        "introduction": task.introduction,
        "items": [
            {"id": str(item_id), "name": task.item(item_key(str(item_id))).name}
            for item_id in interaction.presented_order
        ],
    }


def _questionnaire(flow: Flow, position: int, robot_name: str | None) -> PhoneState:
    pages = questionnaires_for(flow, position)
    done = answered(flow, position)
    remaining = [q for q in pages if q.id not in done]
    if not remaining:  # everything stored; the flow moves on with the next change
        return {"view": "waiting", "position": position, "after": True}
    page = remaining[0]
    return {
        "view": "questionnaire",
        "position": position,
        "final": position == FINAL_POSITION,
        "robot_name": robot_name,
        "page": pages.index(page) + 1,
        "pages": len(pages),
        "questionnaire": questionnaire_wording(page),
    }


def questionnaire_wording(questionnaire: Questionnaire) -> PhoneState:
    return {
        "id": questionnaire.id,
        "points": questionnaire.points,
        "low": questionnaire.low,
        "high": questionnaire.high,
        "items": [
            {
                "id": item.id,
                "type": item.type,
                "text": item.text,
                "left": item.left,
                "right": item.right,
                "required": item.required,
            }
            for item in questionnaire.items
        ],
    }
