"""Data-quality flags for sessions: what a PI must look at before trusting the data.

Besides those below, :mod:`.run_flags` flags sessions never started, ended early, partly
run interactions, excluded participants and prompts the robot did not voice.

- missing answers: a finished interaction (or a complete session's final questionnaire)
  without an answer to every item of its questionnaires;
- plan deviations: an interaction run in another condition than planned, or a deviation
  event the session flow logged;
- outages: worker or robot outage / disconnection events, and prompts the worker never
  got (``prompt.not_sent``), during an interaction (by interaction id, or by time);
- synchrony: a copy interaction whose robot did not follow the participant at the configured
  delay, above the surrogate band (:mod:`chameleons.backend.synchrony.flags`);
- wizard-latency outliers: a latency in an event payload (``click_to_ack_ms``,
  ``click_to_speech_ms``, any ``*latency_ms``) above ``LATENCY_LIMIT_MS``, or above the
  study's own upper fence for that latency (third quartile + 3 x IQR, with enough values).
"""

from __future__ import annotations

import re
from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from statistics import quantiles
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.dashboard.run_flags import run_flags
from chameleons.backend.export.selection import as_utc
from chameleons.backend.models import Event, Interaction, QuestionnaireResponse, Session
from chameleons.backend.synchrony.flags import synchrony_flags
from chameleons.experiment.model import Study as StudySpec

LATENCY_LIMIT_MS = 1500.0
MIN_VALUES_FOR_FENCE = 20
# Worker/robot trouble: outage-like events of the worker, robot, bridge or display, and a
# prompt the worker never received (``prompt.not_sent``). A phone reconnecting is not one.
OUTAGE_KIND = re.compile(
    r"^(worker|robot|bridge|display)\.\w*(down|lost|disconnect|outage|restart|died|unreachable"
    r"|timeout)|outage|^prompt\.not_sent$"
)
DEVIATION_KIND = re.compile(r"deviation")
FINISHED_STEPS = frozenset({"done"})


@dataclass(frozen=True)
class Flag:
    kind: str  # missing_answers | deviation | outage | latency | see run_flags
    position: int | None
    text: str
    event_id: int | None = None


@dataclass
class SessionFlags:
    flags: list[Flag] = field(default_factory=list)

    def of(self, kind: str) -> list[Flag]:
        return [flag for flag in self.flags if flag.kind == kind]

    @property
    def kinds(self) -> list[str]:
        return sorted({flag.kind for flag in self.flags})

    @property
    def flagged_events(self) -> set[int]:
        return {flag.event_id for flag in self.flags if flag.event_id is not None}


def latencies(payload: Any) -> list[tuple[str, float]]:
    """Every latency (ms) in a payload, nested objects included."""
    found: list[tuple[str, float]] = []
    if isinstance(payload, dict):
        for key, value in payload.items():
            numeric = isinstance(value, int | float) and not isinstance(value, bool)
            if numeric and _is_latency(key):
                found.append((key, float(value)))
            else:
                found.extend(latencies(value))
    return found


def _is_latency(key: str) -> bool:
    return key.endswith("latency_ms") or (key.startswith("click_to_") and key.endswith("_ms"))


def latency_limits(events: Iterable[Event]) -> dict[str, float]:
    """Per latency name: the limit above which a value is an outlier."""
    values: dict[str, list[float]] = defaultdict(list)
    for event in events:
        for key, value in latencies(event.payload):
            values[key].append(value)
    limits = {}
    for key, series in values.items():
        limit = LATENCY_LIMIT_MS
        if len(series) >= MIN_VALUES_FOR_FENCE:
            q1, _, q3 = quantiles(series, n=4)
            limit = min(limit, q3 + 3 * (q3 - q1))
        limits[key] = limit
    return limits


def _expected_items(spec: StudySpec) -> tuple[set[tuple[str, str]], set[tuple[str, str]]]:
    per_interaction = {
        (q.id, item.id) for q in spec.questionnaires_for("interaction") for item in q.items
    }
    final = {(q.id, item.id) for q in spec.questionnaires_for("final") for item in q.items}
    return per_interaction, final


def session_flags(
    db: DbSession,
    spec: StudySpec,
    sessions: list[Session],
    limits: dict[str, float] | None = None,
) -> dict[int, SessionFlags]:
    """Flags for each given session (one query per table, not per session)."""
    ids = [session.id for session in sessions]
    result = {session_id: SessionFlags() for session_id in ids}
    if not ids:
        return result
    interactions = list(db.scalars(select(Interaction).where(Interaction.session_id.in_(ids))))
    events = list(db.scalars(select(Event).where(Event.session_id.in_(ids)).order_by(Event.id)))
    answers: dict[tuple[int, int], set[tuple[str, str]]] = defaultdict(set)
    query = select(
        QuestionnaireResponse.session_id,
        QuestionnaireResponse.position,
        QuestionnaireResponse.questionnaire,
        QuestionnaireResponse.item,
    ).where(QuestionnaireResponse.session_id.in_(ids))
    for session_id, position, questionnaire, item in db.execute(query):
        answers[(session_id, position)].add((questionnaire, item))
    _missing_answers(spec, sessions, interactions, answers, result)
    _deviations(interactions, events, result)
    _event_flags(interactions, events, limits or latency_limits(events), result)

    def add(session_id: int, kind: str, position: int | None, text: str, event: int | None) -> None:
        result[session_id].flags.append(Flag(kind, position, text, event))

    run_flags(db, sessions, interactions, events, spec.suggestions_per_interaction, add)
    synchrony_flags(db, interactions, add)
    return result


def _missing_answers(
    spec: StudySpec,
    sessions: list[Session],
    interactions: list[Interaction],
    answers: dict[tuple[int, int], set[tuple[str, str]]],
    result: dict[int, SessionFlags],
) -> None:
    per_interaction, final = _expected_items(spec)
    for interaction in interactions:
        if interaction.state in FINISHED_STEPS:
            missing = per_interaction - answers[(interaction.session_id, interaction.position)]
            if missing:
                text = f"interaction {interaction.position}: {len(missing)} answer(s) missing"
                flag = Flag("missing_answers", interaction.position, text)
                result[interaction.session_id].flags.append(flag)
    for session in sessions:
        if session.state == "complete":
            missing = final - answers[(session.id, 0)]
            if missing:
                text = f"final questionnaire: {len(missing)} answer(s) missing"
                result[session.id].flags.append(Flag("missing_answers", 0, text))


def _deviations(
    interactions: list[Interaction], events: list[Event], result: dict[int, SessionFlags]
) -> None:
    logged = {event.interaction_id for event in events if DEVIATION_KIND.search(event.kind)}
    for interaction in interactions:
        if interaction.condition != interaction.planned_condition:
            text = (
                f"interaction {interaction.position}: ran {interaction.condition}, "
                f"planned {interaction.planned_condition}"
            )
            result[interaction.session_id].flags.append(
                Flag("deviation", interaction.position, text)
            )
        elif interaction.id in logged:
            text = f"interaction {interaction.position}: deviation logged"
            result[interaction.session_id].flags.append(
                Flag("deviation", interaction.position, text)
            )


def _event_flags(
    interactions: list[Interaction],
    events: list[Event],
    limits: dict[str, float],
    result: dict[int, SessionFlags],
) -> None:
    positions = {interaction.id: interaction.position for interaction in interactions}
    for event in events:
        if event.session_id is None:
            continue
        position = positions.get(event.interaction_id) if event.interaction_id else None
        if position is None:
            position = _running_at(interactions, event)
        flags = result[event.session_id].flags
        if OUTAGE_KIND.search(event.kind) and position is not None:
            text = f"interaction {position}: {event.kind}"
            flags.append(Flag("outage", position, text, event.id))
        for key, value in latencies(event.payload):
            if value > limits.get(key, LATENCY_LIMIT_MS):
                where = f"interaction {position}" if position else "session"
                text = f"{where}: {key} {value:.0f} ms in {event.kind}"
                flags.append(Flag("latency", position, text, event.id))


def _running_at(interactions: list[Interaction], event: Event) -> int | None:
    """The position of the session's interaction running when a session-level event came."""
    moment = as_utc(event.server_time)
    for interaction in interactions:
        if interaction.session_id != event.session_id or interaction.started_at is None:
            continue
        start, end = as_utc(interaction.started_at), as_utc(interaction.ended_at)
        if (
            moment is not None
            and start is not None
            and start <= moment
            and (end is None or moment <= end)
        ):
            return interaction.position
    return None
