"""The participant's submissions: the ranking and the questionnaires.

Each submission carries a client-generated id. The id is stored with the submission's
event in the same transaction (unique per session), so a resubmission finds the stored
result instead of storing twice. Bad input (422) and a submission at the wrong moment
(409) change nothing.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from sqlalchemy import bindparam, select

from chameleons.backend.events import repository as events
from chameleons.backend.models import Event, Interaction, QuestionnaireResponse
from chameleons.backend.sessions.consent import BEFORE_POSITION, waiting_before_start
from chameleons.backend.sessions.flow import Flow
from chameleons.backend.sessions.pausing import refuse_phone_if_paused
from chameleons.backend.sessions.states import STEPS
from chameleons.backend.studies.errors import ConflictError, GoneError, InvalidInputError
from chameleons.experiment.model import Questionnaire, QuestionnaireItem
from chameleons.i18n import N_

MAX_TEXT_LENGTH = 5000
FINAL_POSITION = 0
DONT_KNOW = "dont_know"  # a robot item's answer when the participant cannot tell


def submit_ranking(flow: Flow, client_id: str, position: int, ranking: list[str]) -> Event:
    _check_open(flow)
    interaction = flow.interaction(position)
    if interaction.initial_ranking is not None:
        raise ConflictError(N_("Your ranking for this round was already saved."))
    if flow.session.state != "running" or interaction.state != "ranking":
        raise ConflictError(N_("The ranking is not open at the moment."))
    _check_permutation(ranking, interaction.presented_order)
    interaction.initial_ranking = list(ranking)
    interaction.current_ranking = list(ranking)
    return flow.log(  # its flush writes the ranking too (one flush, not two)
        "ranking.submitted",
        source="participant",
        interaction=interaction,
        client_id=client_id,
        payload={"position": position, "ranking": list(ranking)},
    )


def _check_permutation(ranking: list[str], presented: list[Any]) -> None:
    expected = [str(item) for item in presented]
    if len(ranking) != len(expected) or sorted(ranking) != sorted(expected):
        raise InvalidInputError(
            N_("The ranking must contain each of the {count} items exactly once."),
            count=len(expected),
        )


def questionnaires_for(flow: Flow, position: int) -> tuple[Questionnaire, ...]:
    if position == BEFORE_POSITION:
        return flow.spec.questionnaires_for("before")
    return flow.spec.questionnaires_for("final" if position == FINAL_POSITION else "interaction")


# Built once (see sessions.flow.SUGGESTIONS_OF_INTERACTIONS): every page and snapshot asks.
ANSWERED_BY_POSITION = (
    select(QuestionnaireResponse.position, QuestionnaireResponse.questionnaire)
    .distinct()
    .where(QuestionnaireResponse.session_id == bindparam("session_id"))
)


def answered(flow: Flow, position: int) -> set[str]:
    """Ids of the questionnaires of this position already stored (a copy)."""
    return set(_answered_memo(flow).get(position, ()))


def answered_by_position(flow: Flow) -> dict[int, set[str]]:
    """``answered`` for every position of the session that has answers (copies)."""
    return {position: set(ids) for position, ids in _answered_memo(flow).items() if ids}


def _answered_memo(flow: Flow) -> dict[int, set[str]]:
    """Every position's stored questionnaire ids, known once per flow: a page's submission
    asks several times (may it store, is the part done, what does the phone see next, the
    console's state it leaves), and its one writer keeps the memo current
    (``submit_questionnaire``). Read in one query, and only if a part may have answers
    this process does not know (``_part``; issue 34)."""
    positions = (BEFORE_POSITION, *range(1, len(flow.interactions) + 1), FINAL_POSITION)
    missing = [position for position in positions if position not in flow.answered_memo]
    if not missing:
        return flow.answered_memo
    token = flow.session.phone_token
    parts = {position: _part(flow, position) for position in missing}
    known = {position: _known(token, position, part) for position, part in parts.items()}
    if all(ids is not None for ids in known.values()):
        flow.answered_memo.update({position: set(ids or ()) for position, ids in known.items()})
        return flow.answered_memo
    found: dict[int, set[str]] = {position: set() for position in positions}
    for position, questionnaire in flow.db.execute(
        ANSWERED_BY_POSITION, {"session_id": flow.session.id}
    ):
        found.setdefault(position, set()).add(questionnaire)
    for position, part in parts.items():
        if part == CLOSED:
            events.keep_once_committed(flow.db, _CLOSED, (token, position),
                                       frozenset(found[position]), _CLOSED_MAX)  # fmt: skip
    flow.answered_memo.update({position: found[position] for position in missing})
    return flow.answered_memo


# Answers are stored only while their part is open (``_questionnaire_target``) and states
# only move on (``sessions.states``): a part not open yet has none, and a part closed for
# good keeps what it had. A closed part's ids are kept per (session link, position) once a
# committed state showed them closed, so a submission reads answers only while a part is
# open (issue 34). The link is the key: a withdrawal may free a session's id, not its link.
NOT_YET, OPEN, CLOSED = "not yet open", "open", "closed"
STEPS_BEFORE_QUESTIONNAIRE = STEPS[: STEPS.index("questionnaire")]
_CLOSED: dict[tuple[str, int], frozenset[str]] = {}
_CLOSED_MAX = 4096  # a server's sessions x parts; emptied when full


def _known(token: str, position: int, part: str) -> frozenset[str] | None:
    """The ids of ``position`` if this process knows them without a read, else None."""
    if part == NOT_YET:
        return frozenset()
    return _CLOSED.get((token, position)) if part == CLOSED else None


def _part(flow: Flow, position: int) -> str:
    """Whether answers of ``position`` may be stored now, later, or never again."""
    state = flow.session.state
    if position == BEFORE_POSITION:
        return OPEN if state == "pending" else CLOSED
    if position == FINAL_POSITION:
        if state in ("pending", "running"):
            return NOT_YET
        return OPEN if state == "final_questionnaire" else CLOSED
    step = flow.interaction(position).state
    if step in STEPS_BEFORE_QUESTIONNAIRE:
        return NOT_YET
    return OPEN if step == "questionnaire" and state == "running" else CLOSED


def submit_questionnaire(
    flow: Flow, client_id: str, position: int, questionnaire_id: str, answers: dict[str, Any]
) -> Event:
    _check_open(flow)
    interaction = _questionnaire_target(flow, position)
    questionnaire = next(
        (q for q in questionnaires_for(flow, position) if q.id == questionnaire_id), None
    )
    if questionnaire is None:
        raise InvalidInputError(N_("These questions do not belong to this part of the study."))
    if questionnaire.id in answered(flow, position):
        raise ConflictError(N_("You have already answered these questions."))
    values = _validated(questionnaire, answers, len(flow.interactions))
    for item_id, value in values.items():
        # A skipped optional item is stored as skipped (empty in the export), so the
        # data say it was shown and left out; it is never given a default value.
        flow.db.add(
            QuestionnaireResponse(
                session_id=flow.session.id,
                interaction_id=interaction.id if interaction else None,
                position=position,
                questionnaire=questionnaire.id,
                version=questionnaire.version,
                item=item_id,
                value=value if isinstance(value, int) else None,
                text=value if isinstance(value, str) else None,
                skipped=value is None,
            )
        )
    flow.db.flush()
    flow.answered_memo[position].add(questionnaire.id)  # read just above, by the check
    event = flow.log(
        "questionnaire.submitted",
        source="participant",
        interaction=interaction,
        client_id=client_id,
        payload={
            "position": position,
            "questionnaire": questionnaire.id,
            "version": questionnaire.version,
            "items": len(values),
            "skipped": sorted(item for item, value in values.items() if value is None),
        },
    )
    if interaction is not None:
        finish_interaction_if_answered(flow, interaction)
    elif position == FINAL_POSITION:
        _complete_if_answered(flow)
    return event


def _check_open(flow: Flow) -> None:
    if flow.session.state in ("complete", "ended"):
        raise GoneError(N_("This session has ended. Thank you for taking part!"))
    refuse_phone_if_paused(flow)


def _questionnaire_target(flow: Flow, position: int) -> Interaction | None:
    if position == BEFORE_POSITION:
        if flow.session.state != "pending" or waiting_before_start(flow) == "consent":
            raise ConflictError(N_("These questions are not open at the moment."))
        return None
    if position == FINAL_POSITION:
        if flow.session.state != "final_questionnaire":
            raise ConflictError(N_("The final questions are not open yet."))
        return None
    interaction = flow.interaction(position)
    if flow.session.state != "running" or interaction.state != "questionnaire":
        if interaction.state == "done":
            raise ConflictError(N_("You have already answered these questions."))
        raise ConflictError(N_("These questions are not open at the moment."))
    return interaction


def _validated(
    questionnaire: Questionnaire, answers: dict[str, Any], robots: int
) -> dict[str, int | str | None]:
    """item id -> answer, None for a skipped optional item."""
    known = {item.id for item in questionnaire.items}
    unknown = sorted(set(answers) - known)
    if unknown:
        raise InvalidInputError(N_("Unknown question(s): {ids}."), ids=", ".join(unknown))
    values: dict[str, int | str | None] = {}
    for number, item in enumerate(questionnaire.items, start=1):
        values[item.id] = _value(questionnaire, item, number, answers.get(item.id), robots)
    return values


def _value(
    questionnaire: Questionnaire, item: QuestionnaireItem, number: int, raw: Any, robots: int
) -> int | str | None:
    if raw is None or (isinstance(raw, str) and not raw.strip()):
        if item.required:
            raise InvalidInputError(N_("Please answer question {number}."), number=number)
        return None
    if item.type in ("choice", "robot"):
        return _chosen(item, number, raw, robots)
    if item.numeric:
        points = questionnaire.points
        if isinstance(raw, bool) or not isinstance(raw, int) or not 1 <= raw <= points:
            raise InvalidInputError(
                N_("The answer to question {number} must be a whole number from 1 to {points}."),
                number=number,
                points=points,
            )
        return int(raw)
    if not isinstance(raw, str):
        raise InvalidInputError(N_("The answer to question {number} must be text."), number=number)
    text = raw.strip()
    if len(text) > MAX_TEXT_LENGTH:
        raise InvalidInputError(
            N_("The answer to question {number} is longer than {limit} characters."),
            number=number,
            limit=MAX_TEXT_LENGTH,
        )
    return text


def _chosen(item: QuestionnaireItem, number: int, raw: Any, robots: int) -> int | str:
    """A choice's option id (stored as text); a robot item's robot by its position in the
    session (stored as value), or ``dont_know`` (stored as text)."""
    if item.type == "choice":
        if isinstance(raw, str) and raw in {option.id for option in item.options}:
            return str(raw)
        raise InvalidInputError(
            N_("Please choose one of the answers to question {number}."), number=number
        )
    if raw == DONT_KNOW:
        return DONT_KNOW
    if isinstance(raw, bool) or not isinstance(raw, int) or not 1 <= raw <= robots:
        raise InvalidInputError(
            N_("Please choose one of the robots in question {number}."), number=number
        )
    return int(raw)


def finish_interaction_if_answered(flow: Flow, interaction: Interaction) -> None:
    """All of the interaction's questionnaires stored: the interaction is done; after the
    last interaction the final questionnaire opens (or the session completes without one)."""
    if interaction.state != "questionnaire":
        return
    needed = {q.id for q in questionnaires_for(flow, interaction.position)}
    if not needed <= answered(flow, interaction.position):
        return
    interaction.state = "done"
    interaction.ended_at = datetime.now(UTC)
    flow.db.flush()
    flow.log(
        "interaction.advanced",
        source="participant",
        interaction=interaction,
        payload={"position": interaction.position, "from": "questionnaire", "to": "done"},
    )
    if interaction.position == len(flow.interactions):
        flow.session.state = "final_questionnaire"
        flow.db.flush()
        flow.log("session.final_questionnaire", source="participant")
        _complete_if_answered(flow)


def _complete_if_answered(flow: Flow) -> None:
    needed = {q.id for q in questionnaires_for(flow, FINAL_POSITION)}
    if flow.session.state != "final_questionnaire" or not needed <= answered(flow, FINAL_POSITION):
        return
    flow.session.state = "complete"
    flow.session.completed_at = datetime.now(UTC)
    flow.participant.status = "complete"
    flow.db.flush()
    flow.log("session.completed", source="participant")
