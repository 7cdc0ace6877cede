"""Creating sessions and moving them forward: the wizard's side of the state machine.

Every function checks the current state first and raises ``ConflictError`` (409) with a
sentence saying why and what is allowed now; nothing changes on a refusal. Flushes only.
"""

from __future__ import annotations

import secrets
from datetime import UTC, datetime

from sqlalchemy import select
from sqlalchemy.orm import Session

from chameleons.backend.models import Event, Interaction, Participant, PlanRow
from chameleons.backend.models import Session as SessionRow
from chameleons.backend.models import Study as StudyRow
from chameleons.backend.sessions import negotiation
from chameleons.backend.sessions.answers import finish_interaction_if_answered
from chameleons.backend.sessions.consent import waiting_before_start
from chameleons.backend.sessions.flow import Flow, load
from chameleons.backend.sessions.pausing import refuse_if_paused
from chameleons.backend.sessions.states import NEXT_STEP, WIZARD_STEPS
from chameleons.backend.studies import service as studies
from chameleons.backend.studies.errors import (
    ConfirmationNeededError,
    ConflictError,
    InvalidInputError,
)
from chameleons.backend.studies.specs import spec_of
from chameleons.experiment.model import Study

# No 0/O, 1/I/L, 2/Z, 5/S, 8/B: easy to read aloud and to type on a phone.
SHORT_CODE_ALPHABET = "ACDEFGHJKMNPQRTUVWXY34679"
SHORT_CODE_LENGTH = 6


def new_phone_token() -> str:
    return secrets.token_urlsafe(32)  # 256 bits


def new_short_code(db: Session) -> str:
    while True:
        code = "".join(secrets.choice(SHORT_CODE_ALPHABET) for _ in range(SHORT_CODE_LENGTH))
        if db.scalars(select(SessionRow.id).where(SessionRow.short_code == code)).first() is None:
            return code


def create_session(
    db: Session,
    study: StudyRow,
    participant: Participant,
    booth: str = "booth-1",
    language: str | None = None,
) -> Flow:
    """The participant's session on ``booth``, in ``language`` (the study's default when
    none is given; the phone may still change it before consent)."""
    if participant.study_id != study.id:
        raise InvalidInputError(f"Participant {participant.code} belongs to another study.")
    existing = db.scalars(
        select(SessionRow.id).where(SessionRow.participant_id == participant.id)
    ).first()
    if existing is not None:
        raise ConflictError(
            f"Participant {participant.code} already has session {existing}; "
            "a participant runs through the study once."
        )
    row = _row_for(db, study, participant)
    chosen = session_language(spec_of(study), language)
    session = SessionRow(
        language=chosen,
        study_id=study.id,
        participant_id=participant.id,
        plan_row_id=row.id,
        booth=booth,
        state="pending",
        current_position=1,
        phone_token=new_phone_token(),
        short_code=new_short_code(db),
        is_rehearsal=participant.is_rehearsal,
    )
    db.add(session)
    db.flush()
    for planned in row.interactions:
        db.add(_interaction(session, planned))
    db.flush()
    flow = load(db, session.id)
    flow.log(
        "session.created",
        source="staff",
        payload={
            "participant": participant.code,
            "row_number": row.row_number,
            "booth": booth,
            "rehearsal": participant.is_rehearsal,
            "language": chosen,
        },
    )
    return flow


def session_language(spec: Study, language: str | None) -> str:
    """``language`` when the study declares it, the study's default when none is given."""
    if not language:
        return spec.default_language
    if language not in spec.languages:
        raise InvalidInputError(
            f"The study has no language {language!r} (its languages: {', '.join(spec.languages)})."
        )
    return language


def _row_for(db: Session, study: StudyRow, participant: Participant) -> PlanRow:
    if participant.plan_row_id is not None:
        row = db.get(PlanRow, participant.plan_row_id)
        if row is not None:
            return row
    # A rehearsal borrows a row without holding it (see ``studies.rehearsal_row``).
    row = studies.rehearsal_row(db, study)
    if row is None:
        raise ConflictError("The study has no plan yet. Generate the plan first.")
    return row


def _interaction(session: SessionRow, planned: dict[str, object]) -> Interaction:
    order = [str(item) for item in planned["item_order"]]  # type: ignore[attr-defined]
    return Interaction(
        session_id=session.id,
        position=int(planned["position"]),  # type: ignore[call-overload]
        state="pending",
        planned_condition=str(planned["condition"]),
        condition=str(planned["condition"]),
        actor=str(planned["actor"]),
        robot_name=str(planned["robot_name"]),
        face=str(planned["face"]),
        task=str(planned["task"]),
        item_set=str(planned["item_set"]),
        presented_order=order,
    )


def start(flow: Flow, worker_time: float | None = None) -> None:
    if flow.session.state != "pending":
        raise flow.refuse(f"The session has already started (it is {flow.session.state}).")
    waiting = waiting_before_start(flow)
    if waiting == "consent":
        raise flow.refuse("The session cannot start before the participant has given consent.")
    if waiting == "before":
        raise flow.refuse("The participant has not answered the questions before the session.")
    flow.session.state = "running"
    flow.session.started_at = datetime.now(UTC)
    flow.participant.status = "active"
    flow.db.flush()
    flow.log("session.started", worker_time=worker_time, payload={"booth": flow.session.booth})


def advance(flow: Flow, position: int, to: str, worker_time: float | None = None) -> Interaction:
    if to not in WIZARD_STEPS:
        raise InvalidInputError(
            f"{to!r} is not a step the wizard can move to; use one of {', '.join(WIZARD_STEPS)}."
        )
    state = flow.session.state
    if state == "pending":
        raise flow.refuse("The session has not started yet.")
    if state != "running":
        raise flow.refuse(f"The interactions are over (the session is {state}).")
    refuse_if_paused(flow, f"moving interaction {position} to {to}")
    interaction = flow.interaction(position)
    _check_is_current(flow, interaction, to)
    if interaction.state == to:
        raise flow.refuse(f"Interaction {position} is already in {to}.")
    if NEXT_STEP.get(interaction.state) != to:
        raise flow.refuse(
            f"Interaction {position} is in {interaction.state}; it cannot move to {to}."
        )
    _check_guards(flow, interaction, to)
    before = interaction.state
    interaction.state = to
    flow.session.current_position = position
    _enter(flow, interaction, to)
    flow.db.flush()
    flow.log(
        "interaction.advanced",
        interaction=interaction,
        worker_time=worker_time,
        payload={"position": position, "from": before, "to": to},
    )
    if to == "negotiation":
        negotiation.propose_next(flow, interaction)
    if to == "questionnaire":
        finish_interaction_if_answered(flow, interaction)
    return interaction


def _check_is_current(flow: Flow, interaction: Interaction, to: str) -> None:
    current = flow.current
    if interaction.position == current.position:
        return
    starts_next = (
        interaction.position == current.position + 1
        and current.state == "done"
        and to == "discussion"
    )
    if starts_next:
        return
    if interaction.position < current.position:
        raise flow.refuse(f"Interaction {interaction.position} is over ({interaction.state}).")
    raise flow.refuse(
        f"Interaction {interaction.position} cannot start before interaction "
        f"{current.position} is done (it is in {current.state})."
    )


def _check_guards(flow: Flow, interaction: Interaction, to: str) -> None:
    position = interaction.position
    if to == "negotiation" and interaction.initial_ranking is None:
        raise flow.refuse(
            f"The participant has not submitted the ranking of interaction {position} yet."
        )
    if to == "questionnaire":
        decided = [s for s in flow.suggestions(interaction) if s.accepted is not None]
        needed = negotiation.suggestion_count(flow)
        if len(decided) < needed:
            raise flow.refuse(
                f"Only {len(decided)} of the {needed} suggestions of interaction {position} "
                "are decided."
            )


def _enter(flow: Flow, interaction: Interaction, to: str) -> None:
    now = datetime.now(UTC)
    if to == "discussion":
        interaction.started_at = now
    elif to == "negotiation":
        interaction.current_ranking = list(interaction.initial_ranking or [])
    elif to == "questionnaire":
        interaction.final_ranking = list(interaction.current_ranking or [])


def switch_condition(
    flow: Flow,
    condition: str,
    position: int | None = None,
    worker_time: float | None = None,
    confirm_deviation: bool = False,
) -> Interaction:
    """Record the condition actually run; a difference from the plan is logged as a deviation.

    A switch to a condition another interaction of this session has already run (the
    participant would have it twice and miss another) is refused until confirmed."""
    if condition not in flow.spec.condition_ids:
        raise InvalidInputError(
            f"{condition!r} is not a condition of this study; use one of "
            f"{', '.join(flow.spec.condition_ids)}."
        )
    if flow.session.state in ("final_questionnaire", "complete", "ended"):
        raise flow.refuse(f"The interactions are over (the session is {flow.session.state}).")
    interaction = flow.interaction(position) if position is not None else _upcoming(flow)
    if interaction.state == "done":
        raise flow.refuse(f"Interaction {interaction.position} is over; its condition is history.")
    before = interaction.condition
    if before == condition:
        return interaction
    repeated = [
        i.position
        for i in flow.interactions
        if i.state == "done" and i.condition == condition and i is not interaction
    ]
    if repeated and not confirm_deviation:
        raise ConfirmationNeededError(
            f"Interaction {repeated[0]} already ran {condition}: switching interaction "
            f"{interaction.position} to {condition} gives this participant {condition} twice "
            f"and no {before}. Confirm it as a deviation from the plan to go ahead.",
            "confirm_deviation",
        )
    interaction.condition = condition
    flow.db.flush()
    payload: dict[str, object] = {
        "position": interaction.position,
        "from": before,
        "to": condition,
        "planned": interaction.planned_condition,
    }
    if repeated:
        payload.update(repeats_position=repeated[0], confirmed=True)
    flow.log(
        "condition.switched", interaction=interaction, worker_time=worker_time, payload=payload
    )
    if condition != interaction.planned_condition:
        flow.log(
            "plan.deviation", interaction=interaction, payload={**payload, "field": "condition"}
        )
    return interaction


def _upcoming(flow: Flow) -> Interaction:
    """The interaction running now, or the next one when the current one is done."""
    current = flow.current
    if current.state == "done" and not flow.is_last:
        return flow.interaction(current.position + 1)
    return current


def add_wizard_note(flow: Flow, text: str) -> Event:
    """The wizard's observation, stamped with the interaction and step the session is in
    (exported in the events table; shown in the console's and the PI's timelines)."""
    position = flow.session.current_position
    running = flow.session.state == "running" and 1 <= position <= len(flow.interactions)
    interaction = flow.interaction(position) if running else None
    step = interaction.state if interaction is not None else flow.session.state
    payload: dict[str, object] = {"text": text, "position": position if running else None,
                                  "step": step}  # fmt: skip
    return flow.log("wizard.note", interaction=interaction, payload=payload)


def log_note(
    flow: Flow,
    kind: str,
    payload: dict[str, object],
    position: int | None = None,
    worker_time: float | None = None,
) -> None:
    """A wizard-side timeline entry (prompt played, note...), kept under ``wizard.``."""
    interaction = flow.interaction(position) if position is not None else None
    flow.log(f"wizard.{kind}", interaction=interaction, worker_time=worker_time, payload=payload)
