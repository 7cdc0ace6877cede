"""Row generators for the export tables, read from the database in batches.

Each generator yields plain dicts keyed by the table's column names (see
:mod:`columns`), already in export shape: ISO times, lists joined, booleans as bools.
Rehearsals are filtered in SQL, so every table agrees on which sessions count.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from datetime import datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.columns import LIST_SEPARATOR
from chameleons.backend.export.copy_realised import realised_columns, realised_values
from chameleons.backend.export.queries import (
    BATCH,
    counted_interactions,
    joined,
    recording_problems,
    session_filter,
)
from chameleons.backend.export.scoring import error_score
from chameleons.backend.export.selection import as_utc, iso
from chameleons.backend.export.synchrony_columns import synchrony_values
from chameleons.backend.models import (
    Event,
    Interaction,
    Participant,
    PlanRow,
    QuestionnaireResponse,
    Session,
    Study,
    Suggestion,
)
from chameleons.experiment.model import Study as StudySpec

Row = dict[str, Any]


def _seconds(start: datetime | None, end: datetime | None) -> float | None:
    first, last = as_utc(start), as_utc(end)
    if first is None or last is None:
        return None
    return round((last - first).total_seconds(), 3)


def _joined_list(items: list[Any] | None) -> str | None:
    return None if items is None else LIST_SEPARATOR.join(str(item) for item in items)


def participant_rows(db: DbSession, study: Study, include_rehearsal: bool) -> Iterator[Row]:
    query = (
        select(Participant, Session, PlanRow.row_number)
        .join(Session, Session.participant_id == Participant.id)
        .join(PlanRow, PlanRow.id == Session.plan_row_id)
        .where(*session_filter(study.id, include_rehearsal))
        .order_by(Participant.code, Session.id)
    )
    last: dict[str, Row] = {}  # a participant's last session wins
    for participant, session, row_number in db.execute(query):
        last[participant.code] = {
            "participant": participant.code,
            "plan_row": row_number,
            "status": participant.status,
            "rehearsal": participant.is_rehearsal or session.is_rehearsal,
            "session": session.id,
            "booth": session.booth,
            "language": session.language,
            "session_state": session.state,
            "consent_at": iso(session.consent_at or participant.consent_at),
            "video_consent": session.video_consent,
            "video_audio_consent": session.video_audio_consent,
            "started_at": iso(session.started_at),
            "completed_at": iso(session.completed_at),
            "duration_s": _seconds(session.started_at, session.completed_at),
            "ended_at": iso(session.ended_at),
            "end_reason": session.end_reason,
            "end_note": session.end_note,
            "pause_count": session.pause_count,
            "paused_s": round(session.paused_seconds, 3),
            "excluded": participant.excluded_at is not None,
            "exclusion_reason": participant.exclusion_reason,
            "excluded_at": iso(participant.excluded_at),
            "study_config_hash": study.config_hash,
        }
    yield from last.values()


def interaction_rows(
    db: DbSession, study: Study, spec: StudySpec, include_rehearsal: bool
) -> Iterator[Row]:
    actors = {actor.id: actor for actor in spec.actors}
    behaviours = {condition.id: condition.behaviour for condition in spec.conditions}
    problems = recording_problems(db, study.id)
    realised = realised_values(db, study.id)
    nothing_drawn = {column.name: None for column in realised_columns()}
    records = counted_interactions(db, study.id, include_rehearsal)
    synchrony = synchrony_values(db, [record.interaction.id for record in records])
    for record in records:
        interaction = record.interaction
        actor = actors.get(interaction.actor)
        yield {
            "participant": record.code,
            "session": interaction.session_id,
            "position": interaction.position,
            "planned_condition": interaction.planned_condition,
            "condition": interaction.condition,
            "deviation": interaction.condition != interaction.planned_condition,
            "actor": interaction.actor,
            "actor_gender": actor.gender if actor else None,
            "robot_name": interaction.robot_name,
            "face": interaction.face,
            "task": interaction.task,
            "item_set": interaction.item_set,
            "presented_order": _joined_list(interaction.presented_order),
            "initial_ranking": _joined_list(interaction.initial_ranking),
            "final_ranking": _joined_list(interaction.final_ranking),
            "initial_error": error_score(spec, interaction.task, interaction.initial_ranking),
            "final_error": error_score(spec, interaction.task, interaction.final_ranking),
            "accepted": record.accepted(spec.suggestions_per_interaction),
            "suggestions_decided": record.decisions.decided,
            "interaction_status": record.status,
            "started_at": iso(interaction.started_at),
            "ended_at": iso(interaction.ended_at),
            "duration_s": _seconds(interaction.started_at, interaction.ended_at),
            "behaviour": behaviours.get(interaction.condition),
            "natural_source": interaction.natural_source,
            "natural_recording": interaction.natural_recording,
            "renderer": interaction.renderer,
            # issue 31: what the robot's behaviour was told, and the same in words
            "behaviour_params": _params_text(interaction.behaviour_params),
            "behaviour_words": interaction.behaviour_words,
            **realised.get(interaction.id, nothing_drawn),
            "recording_problem": problems.get(interaction.id),
            "face_source": interaction.face_source,
            "face_calibration": interaction.face_calibration,
            **synchrony.get(interaction.id, {}),
        }


def suggestion_rows(db: DbSession, study: Study, include_rehearsal: bool) -> Iterator[Row]:
    query = (
        select(Suggestion, Interaction.session_id, Interaction.position, Interaction.condition)
        .add_columns(Participant.code)
        .join(Interaction, Interaction.id == Suggestion.interaction_id)
        .join(Session, Session.id == Interaction.session_id)
    )
    query = joined(query, study.id, include_rehearsal).order_by(
        Participant.code, Session.id, Interaction.position, Suggestion.index
    )
    for suggestion, session_id, position, condition, code in _streamed(db, query):
        yield {
            "participant": code,
            "session": session_id,
            "position": position,
            "condition": condition,
            "index": suggestion.index,
            "item": suggestion.item,
            "from_rank": suggestion.from_rank,
            "to_rank": suggestion.to_rank,
            "kind": suggestion.kind,
            "accepted": suggestion.accepted,
            "proposed_at": iso(suggestion.proposed_at),
            "decided_at": iso(suggestion.decided_at),
            "decision_s": _seconds(suggestion.proposed_at, suggestion.decided_at),
            "direction": "up" if suggestion.to_rank < suggestion.from_rank else "down",
        }


def _reverse_keyed(spec: StudySpec) -> dict[tuple[str, str], int]:
    """(questionnaire, item) -> scale points, for reverse-keyed items."""
    return {
        (q.id, item.id): q.points for q in spec.questionnaires for item in q.items if item.reverse
    }


def _robot_conditions(
    db: DbSession, study: Study, spec: StudySpec
) -> dict[tuple[int, str, str, int | None], str]:
    """(session, questionnaire, item, answered position) -> that interaction's condition,
    for the study's robot items (the manipulation check names a robot by its position)."""
    items = [(q.id, i.id) for q in spec.questionnaires for i in q.items if i.type == "robot"]
    if not items:
        return {}
    query = (
        select(Interaction.session_id, Interaction.position, Interaction.condition)
        .join(Session, Session.id == Interaction.session_id)
        .where(Session.study_id == study.id)
    )
    return {
        (session_id, questionnaire, item, position): condition
        for session_id, position, condition in db.execute(query)
        for questionnaire, item in items
    }


def questionnaire_rows(
    db: DbSession, study: Study, spec: StudySpec, include_rehearsal: bool
) -> Iterator[Row]:
    reverse = _reverse_keyed(spec)
    robots = _robot_conditions(db, study, spec)
    # Columns, not the ORM entity: a study's answers are most of an export's rows, and
    # building an object for each was most of the analysis page's time (docs/performance.md).
    answer = QuestionnaireResponse
    query = (
        select(
            answer.session_id,
            answer.position,
            answer.questionnaire,
            answer.version,
            answer.item,
            answer.value,
            answer.text,
            answer.skipped,
            answer.created_at,
            Interaction.condition,
            Participant.code,
            Session.language,
        )
        .join(Session, Session.id == answer.session_id)
        .outerjoin(Interaction, Interaction.id == answer.interaction_id)
    )
    query = joined(query, study.id, include_rehearsal).order_by(
        Participant.code,
        Session.id,
        QuestionnaireResponse.position == 0,  # the final questionnaire after the interactions
        QuestionnaireResponse.position,
        QuestionnaireResponse.id,
    )
    for row in _streamed(db, query):
        answer, condition, code, language = row, row.condition, row.code, row.language
        points = reverse.get((answer.questionnaire, answer.item))
        scored = answer.value
        if scored is not None and points is not None:
            scored = points + 1 - scored
        yield {
            "participant": code,
            "session": answer.session_id,
            "position": answer.position,
            "condition": condition,
            "questionnaire": answer.questionnaire,
            "version": answer.version,
            "language": language,
            "item": answer.item,
            "reverse_keyed": points is not None,
            "value": answer.value,
            "scored_value": scored,
            "text": answer.text,
            "named_condition": robots.get(
                (answer.session_id, answer.questionnaire, answer.item, answer.value)
            ),
            "skipped": answer.skipped,
            "answered_at": iso(answer.created_at),
        }


def event_rows(db: DbSession, study: Study, include_rehearsal: bool) -> Iterator[Row]:
    query = (
        select(Event, Participant.code, Interaction.position)
        .join(Session, Session.id == Event.session_id)
        .outerjoin(Interaction, Interaction.id == Event.interaction_id)
    )
    query = joined(query, study.id, include_rehearsal).order_by(Event.server_time, Event.id)
    for event, code, position in _streamed(db, query):
        yield {
            "event": event.id,
            "participant": code,
            "session": event.session_id,
            "position": position,
            "kind": event.kind,
            "source": event.source,
            "server_time": iso(event.server_time),
            "worker_time": event.worker_time,
            "payload": json.dumps(event.payload, sort_keys=True, ensure_ascii=False),
        }


def _streamed(db: DbSession, query: Any) -> Iterator[Any]:
    """The query's rows in batches (a server-side cursor on PostgreSQL), its cursor closed
    also when the reader stops early (the export page previews only the first rows)."""
    with db.execute(query.execution_options(yield_per=BATCH)) as result:
        yield from result


def _params_text(params: dict[str, Any] | None) -> str | None:
    """The behaviour's parameters as canonical JSON (sorted keys), for one cell."""
    if params is None:
        return None
    return json.dumps(params, sort_keys=True, separators=(",", ":"))
