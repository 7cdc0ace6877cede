"""What the participant's phone may know about its session, built field by field.

This is the only source of data sent to the phone (page, JSON, WebSocket). It is built by
whitelisting: robot name, items (id and name), rankings and the questionnaire wording.
Condition, actor, face and plan details never enter it.
"""

from __future__ import annotations

from typing import Any

from chameleons.backend.models import Interaction
from chameleons.backend.sessions.answers import (
    DONT_KNOW,
    FINAL_POSITION,
    answered,
    questionnaires_for,
)
from chameleons.backend.sessions.consent import BEFORE_POSITION, CONSENT_DECLINED
from chameleons.backend.sessions.flow import Flow
from chameleons.backend.sessions.language import may_choose_language
from chameleons.backend.studies.specs import item_key
from chameleons.experiment.model import Questionnaire, QuestionnaireItem, Study
from chameleons.experiment.procedure import paragraphs
from chameleons.i18n import N_, SOURCE_LANGUAGE, gettext, language_name

PhoneState = dict[str, Any]


def texts(flow: Flow) -> Study:
    """The study with the texts in the session's language (what the participant reads)."""
    return flow.spec.in_language(flow.session.language)


def phone_state(flow: Flow, version: int | None = None) -> PhoneState:
    """``version``: the session's newest event id, when the caller has read it already."""
    state = _view(flow)
    state["version"] = flow.newest_event_id() if version is None else version
    state["of"] = len(flow.interactions)
    state["language"] = flow.session.language
    if may_choose_language(flow):  # offered on the first page, before consent
        state["languages"] = [
            {"code": code, "name": language_name(code)} for code in flow.spec.languages
        ]
    return state


def _view(flow: Flow) -> PhoneState:
    session = flow.session
    if session.state in ("complete", "ended"):
        return ended_view(flow)
    if session.paused_at is not None:
        return {"view": "paused", "position": session.current_position}
    if session.state == "pending":
        return _before(flow)
    if session.state == "final_questionnaire":
        return _questionnaire(flow, FINAL_POSITION, robot_name=None)
    current = flow.current
    base = {"position": current.position, "robot_name": current.robot_name}
    step = current.state
    if step in ("pending", "done"):
        return _waiting(current.position, after=step == "done")
    if step == "discussion":
        return {**base, "view": "listen"}
    if step == "ranking" and current.initial_ranking is None:
        return {**base, "view": "ranking", **_task(flow, current)}
    if step in ("ranking", "negotiation"):
        ranking = current.current_ranking or current.initial_ranking or []
        return {**base, "view": "ranked", **_task(flow, current), "ranking": list(ranking)}
    return _questionnaire(flow, current.position, robot_name=current.robot_name)


def _waiting(position: int, after: bool) -> PhoneState:
    """Between the steps; ``first`` before the first conversation (there is no "next" one
    yet). After the last one the final questions follow at once."""
    return {"view": "waiting", "position": position, "after": after,
            "first": not after and position == 1}  # fmt: skip


def ended_view(flow: Flow) -> PhoneState:
    """The last page: a polite goodbye after declining consent; the debriefing (when the
    study has one) after a session that started, complete or ended early."""
    session = flow.session
    if session.end_reason == CONSENT_DECLINED:
        return {"view": "ended", "declined": True}
    debriefing = texts(flow).procedure.debriefing
    if debriefing is None or session.started_at is None:
        return {"view": "ended"}
    language = session.language
    shown = {
        "title": gettext(language, debriefing.title),
        "paragraphs": paragraphs(debriefing.text),
    }
    return {"view": "ended", "debriefing": shown}


def _before(flow: Flow) -> PhoneState:
    """Before the session starts: consent first, then the questions about the participant
    (demographics), then the welcome page until the wizard starts."""
    consent = texts(flow).procedure.consent
    if consent is not None and flow.session.consent_at is None:
        language = flow.session.language  # a default title or button comes translated
        return {
            "view": "consent",
            "consent": {
                "title": gettext(language, consent.title),
                "paragraphs": paragraphs(consent.text),
                "agree": gettext(language, consent.agree),
                "decline": gettext(language, consent.decline),
                "video": _video_items(flow, language),
            },
        }
    if questionnaires_for(flow, BEFORE_POSITION):
        state = _questionnaire(flow, BEFORE_POSITION, robot_name=None)
        if state["view"] == "questionnaire":
            return state
    return {"view": "welcome"}


def _video_items(flow: Flow, language: str) -> dict[str, str | None] | None:
    """The consent page's own video items (unticked; each optional), or None."""
    procedure = texts(flow).procedure
    video = procedure.video
    if video is None or not procedure.records_video:
        return None
    audio = gettext(language, video.audio_label) if video.audio else None
    return {"label": gettext(language, video.label), "audio_label": audio}


def _task(flow: Flow, interaction: Interaction) -> PhoneState:
    task = texts(flow).task(interaction.task)
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
        return _waiting(position, after=True)
    page = remaining[0]
    return {
        "view": "questionnaire",
        "position": position,
        "final": position == FINAL_POSITION,
        "before": position == BEFORE_POSITION,
        "robot_name": robot_name,
        "page": pages.index(page) + 1,
        "pages": len(pages),
        "questionnaire": questionnaire_wording(
            texts(flow).questionnaire(page.id),
            [i.robot_name for i in flow.interactions],
            flow.session.language,
        ),
    }


def questionnaire_wording(
    questionnaire: Questionnaire, robots: list[str], language: str = SOURCE_LANGUAGE
) -> PhoneState:
    """The questions as the phone shows them; a robot item offers the robots the participant
    met, by name in the order met (the position is the answer), and "don't know"."""
    return {
        "id": questionnaire.id,
        "title": questionnaire.title,
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
                "options": _options(item, robots, language),
            }
            for item in questionnaire.items
        ],
    }


def _options(item: QuestionnaireItem, robots: list[str], language: str) -> list[dict[str, Any]]:
    if item.type == "choice":
        return [{"id": option.id, "label": option.label} for option in item.options]
    if item.type == "robot":
        named = [{"id": n, "label": name} for n, name in enumerate(robots, start=1)]
        return [*named, {"id": DONT_KNOW, "label": gettext(language, N_("I don't know"))}]
    return []
