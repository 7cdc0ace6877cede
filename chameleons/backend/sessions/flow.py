"""Loading a session for a change (row-locked) and what may happen next.

``Flow`` bundles the session, its interactions in plan order and the study spec, so the
service functions stay short. ``allowed_actions`` is the single source of "what is legal
now": the 409 sentences and the wizard console's buttons both come from it.
"""

from __future__ import annotations

import functools
from collections.abc import Collection
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import Literal

from sqlalchemy import Select, bindparam, func, select
from sqlalchemy.orm import Session

from chameleons.backend.db import is_read_only, write_transaction
from chameleons.backend.events import repository as events
from chameleons.backend.models import (
    Event,
    Interaction,
    Participant,
    PlanRow,
    QuestionnaireResponse,
    Suggestion,
)
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.models import Study as StudyRow
from chameleons.backend.sessions.states import (
    NEXT_STEP,
    STEPS,
    UNDO_WINDOW_SECONDS,
    Action,
    allowed_sentence,
)
from chameleons.backend.studies.errors import ConflictError, InvalidInputError, NotFoundError
from chameleons.backend.studies.specs import spec_of
from chameleons.experiment.model import Study
from chameleons.i18n import N_

BEFORE_POSITION = -1  # questionnaires answered before the interactions (demographics)

# Statements that every request and live update runs, built once with bound parameters:
# building one and its cache key took about 90 microseconds a call, a few per cent of the
# server's CPU (docs/performance.md, "Statements built once"). Statements are immutable,
# so threads share them.
SUGGESTIONS_OF_INTERACTIONS = (
    select(Suggestion)
    .where(Suggestion.interaction_id.in_(bindparam("ids", expanding=True)))
    .order_by(Suggestion.interaction_id, Suggestion.index)
)
STEPS_BEFORE_NEGOTIATION = STEPS[: STEPS.index("negotiation")]  # no suggestion yet
ROW_NUMBER_OF_PLAN_ROW = select(PlanRow.row_number).where(PlanRow.id == bindparam("id"))
KeyColumn = Literal["id", "phone_token"]  # how a flow is found: the session's id or link
FlowRow = tuple[SessionRow, StudyRow, Participant]
INTERACTIONS_QUERY = (
    select(Interaction)
    .where(Interaction.session_id == bindparam("session_id"))
    .order_by(Interaction.position)
)


def as_utc(moment: datetime) -> datetime:
    """SQLite returns naive datetimes for timezone-aware columns; they are UTC."""
    return moment if moment.tzinfo else moment.replace(tzinfo=UTC)


@dataclass
class Flow:
    db: Session
    session: SessionRow
    study: StudyRow
    spec: Study
    participant: Participant
    interactions: list[Interaction]
    # Questionnaire ids stored per position, read once per flow (a submission asks three
    # times: may it store, is the interaction done, what does the phone see next); the
    # answers' one writer keeps it current (sessions.answers).
    answered_memo: dict[int, set[str]] = field(default_factory=dict)
    # The session's newest event id, read with the session when the flow was loaded to be
    # read only (``_load``): nothing can change it then. None: ask ``events.last_id``.
    version: int | None = None
    # Suggestions per interaction id, read once per flow (a wizard's decision asked four
    # times: is it pending, what comes next, the snapshot, the console's buttons; issue
    # 34); the negotiation, their one writer, keeps it current (``suggestion_added``,
    # ``suggestions_removed``).
    suggestions_memo: dict[int, list[Suggestion]] | None = None

    def newest_event_id(self) -> int:
        """The session's version: read with the session when it was loaded read-only, else
        asked now (after this flow's own changes, if any)."""
        return events.last_id(self.db, self.session.id) if self.version is None else self.version

    def interaction(self, position: int) -> Interaction:
        for interaction in self.interactions:
            if interaction.position == position:
                return interaction
        raise InvalidInputError(
            f"There is no interaction {position}; this session has {len(self.interactions)}."
        )

    @property
    def current(self) -> Interaction:
        return self.interaction(self.session.current_position)

    @property
    def is_last(self) -> bool:
        return self.session.current_position >= len(self.interactions)

    def suggestions(self, interaction: Interaction) -> list[Suggestion]:
        """The interaction's suggestions in order (a copy: change them through the
        negotiation, which keeps the memo)."""
        return list(self._suggestions()[interaction.id])

    def suggestions_by_interaction(
        self, known: Collection[int] = ()
    ) -> dict[int, list[Suggestion]]:
        """``suggestions`` of every interaction (copies), from one query (the snapshot's).
        ``known``: interaction ids whose suggestions the caller has already (settled ones,
        ``sessions.snapshot``): not read unless this flow has read them all already; their
        lists are then empty, and the partial read is not kept."""
        if self.suggestions_memo is None and known:
            found: dict[int, list[Suggestion]] = {i.id: [] for i in self.interactions}
            self._read_suggestions(found, known)
            return found
        return {key: list(found) for key, found in self._suggestions().items()}

    def _suggestions(self) -> dict[int, list[Suggestion]]:
        # Only an interaction that has reached its negotiation can have any (steps only move
        # on, ``sessions.states``; the robot proposes on entering it), so before the first
        # negotiation nothing is asked (issue 34). One entering it later in this flow gets
        # its first suggestion through ``suggestion_added``.
        if self.suggestions_memo is None:
            found: dict[int, list[Suggestion]] = {i.id: [] for i in self.interactions}
            self._read_suggestions(found)
            self.suggestions_memo = found
        return self.suggestions_memo

    def _read_suggestions(
        self, found: dict[int, list[Suggestion]], known: Collection[int] = ()
    ) -> None:
        ids = [i.id for i in self.interactions
               if i.state not in STEPS_BEFORE_NEGOTIATION and i.id not in known]  # fmt: skip
        if ids:
            for suggestion in self.db.scalars(SUGGESTIONS_OF_INTERACTIONS, {"ids": ids}):
                found[suggestion.interaction_id].append(suggestion)

    def suggestion_added(self, suggestion: Suggestion) -> None:
        """A suggestion this flow stored (it comes after the interaction's others)."""
        self._suggestions()[suggestion.interaction_id].append(suggestion)

    def suggestions_removed(self, removed: list[Suggestion]) -> None:
        """Suggestions this flow deleted."""
        for suggestion in removed:
            self._suggestions()[suggestion.interaction_id].remove(suggestion)

    def row_number(self) -> int:
        # The number only (the row's plan, a JSON list, is not needed here).
        found = self.db.scalar(ROW_NUMBER_OF_PLAN_ROW, {"id": self.session.plan_row_id})
        return found or 0

    def log(
        self,
        kind: str,
        *,
        source: str = "wizard",
        interaction: Interaction | None = None,
        payload: dict[str, object] | None = None,
        worker_time: float | None = None,
        client_id: str | None = None,
    ) -> Event:
        return events.record(
            self.db,
            kind,
            source=source,
            study_id=self.session.study_id,
            session_id=self.session.id,
            interaction_id=interaction.id if interaction else None,
            payload=dict(payload or {}),
            worker_time=worker_time,
            client_id=client_id,
        )

    def refuse(self, why: str) -> ConflictError:
        """A 409 with the reason and what is allowed now."""
        return ConflictError(f"{why} {allowed_sentence(allowed_actions(self))}")


def load(db: Session, session_id: int, *, lock: bool = True) -> Flow:
    return _load(db, "id", session_id, lock, f"There is no session {session_id}.")


def load_by_token(db: Session, token: str, *, lock: bool = True) -> Flow:
    return _load(
        db, "phone_token", token, lock,
        N_("This link is not valid. Please ask the experimenter for help."),
    )  # fmt: skip


@functools.cache
def _session_query(column: KeyColumn, lock: bool) -> Select[FlowRow]:
    """The session with its study and participant, by ``column`` (bound as ``key``), built
    once per variant (see ``SUGGESTIONS_OF_INTERACTIONS``)."""
    query = (
        select(SessionRow, StudyRow, Participant)
        .join(StudyRow, StudyRow.id == SessionRow.study_id)
        .join(Participant, Participant.id == SessionRow.participant_id)
        .where(getattr(SessionRow, column) == bindparam("key"))
    )
    # Serialises changes of one session (two wizards, wizard and phone at once): the
    # session's row lock on PostgreSQL (its row only: the study's and participant's are
    # shared); on SQLite FOR UPDATE is a no-op (see db.write_transaction).
    return query.with_for_update(of=SessionRow) if lock else query


# A read-only load takes the session's newest event id (its version) in the same statement:
# one round trip less for every console refresh (docs/performance.md).
_NEWEST_EVENT_OF_SESSION = (
    select(func.max(Event.id)).where(Event.session_id == SessionRow.id).scalar_subquery()
)


@functools.cache
def _versioned_session_query(
    column: KeyColumn,
) -> Select[tuple[SessionRow, StudyRow, Participant, int | None]]:
    return _session_query(column, False).add_columns(_NEWEST_EVENT_OF_SESSION)


def _load(db: Session, column: KeyColumn, key: object, lock: bool, missing: str) -> Flow:
    """The session with its study and participant in one statement (statements are most
    of a request's cost, docs/performance.md), then its interactions. Loaded in a read-only
    session, the flow also carries the session's version, read in the same statement."""
    if lock:
        write_transaction(db)  # SQLite: the write lock first
    versioned = not lock and is_read_only(db)
    query = _versioned_session_query(column) if versioned else _session_query(column, lock)
    found = db.execute(query, {"key": key}).first()
    if found is None:
        raise NotFoundError(missing)
    session, study, participant, *newest = found._tuple()
    interactions = list(db.scalars(INTERACTIONS_QUERY, {"session_id": session.id}))
    flow = Flow(db, session, study, spec_of(study), participant, interactions)
    if versioned:
        flow.version = int(newest[0] or 0)
    return flow


def undo_deadline(suggestion: Suggestion) -> datetime | None:
    if suggestion.decided_at is None:
        return None
    return as_utc(suggestion.decided_at) + timedelta(seconds=UNDO_WINDOW_SECONDS)


def allowed_actions(flow: Flow, now: datetime | None = None) -> list[Action]:
    state = flow.session.state
    if flow.session.paused_at is not None and state not in ("complete", "ended"):
        return [{"action": "resume"}]  # (ending early stays possible, as from any state)
    if state == "pending":
        waiting = waiting_before_start(flow)
        return [{"action": "wait", "for": waiting}] if waiting else [{"action": "start"}]
    if state == "final_questionnaire":
        return [{"action": "wait", "for": "final_questionnaire"}]
    if state == "complete":
        return [{"action": "none"}]
    if state == "ended":
        return [{"action": "none", "why": "ended"}]
    current = flow.current
    position = current.position
    step = current.state
    if step == "done":
        return [{"action": "advance", "position": position + 1, "to": "discussion"}]
    if step == "ranking" and current.initial_ranking is None:
        return [{"action": "wait", "for": "ranking", "position": position}]
    if step == "questionnaire":
        return [{"action": "wait", "for": "questionnaire", "position": position}]
    if step == "negotiation":
        return _negotiation_actions(flow, current, now or datetime.now(UTC))
    return [{"action": "advance", "position": position, "to": NEXT_STEP[step]}]


def _negotiation_actions(flow: Flow, current: Interaction, now: datetime) -> list[Action]:
    suggestions = flow.suggestions(current)
    actions: list[Action] = []
    pending = [s for s in suggestions if s.accepted is None]
    if pending:
        actions.append(
            {"action": "decide", "position": current.position, "index": pending[0].index}
        )
    else:
        actions.append({"action": "advance", "position": current.position, "to": "questionnaire"})
    decided = [s for s in suggestions if s.accepted is not None]
    if decided:
        deadline = undo_deadline(decided[-1])
        if deadline is not None and now <= deadline:
            actions.append(
                {
                    "action": "undo",
                    "position": current.position,
                    "index": decided[-1].index,
                    "until": deadline.isoformat(),
                }
            )
    return actions


def waiting_before_start(flow: Flow) -> str | None:
    """What the session waits for before the wizard may start it: ``consent``, the
    ``before`` questionnaires (demographics), or nothing (None)."""
    if flow.spec.procedure.consent is not None and flow.session.consent_at is None:
        return "consent"
    needed = {q.id for q in flow.spec.questionnaires_for("before")}
    if not needed:
        return None
    query = select(QuestionnaireResponse.questionnaire).where(
        QuestionnaireResponse.session_id == flow.session.id,
        QuestionnaireResponse.position == BEFORE_POSITION,
    )
    return None if needed <= set(flow.db.scalars(query)) else "before"
