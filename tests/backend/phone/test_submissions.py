"""Participant submissions: bad input gets a clear message and changes nothing; a
submission at the wrong moment gets 409; the same client id never stores twice."""

from __future__ import annotations

import random
from collections.abc import Callable
from functools import partial
from typing import Any

import pytest
from sqlalchemy import Engine, func, select

from chameleons.backend.db import build_sessionmaker
from chameleons.backend.models import Event, QuestionnaireResponse
from tests.backend.sessions.conftest import open_ranking, refused, to_negotiation
from tests.support.bots import ParticipantBot, WizardBot, answers_for


def _count(engine: Engine, model: Any, **where: Any) -> int:
    with build_sessionmaker(engine)() as db:
        query = select(func.count()).select_from(model).filter_by(**where)
        return int(db.scalar(query) or 0)


NOT_PERMUTATIONS: dict[str, Callable[[list[str]], list[str]]] = {
    "an item missing": lambda r: r[:-1],
    "an extra item": lambda r: [*r, "stowaway"],
    "an item twice": lambda r: [r[0], *r[:-1]],
    "an unknown item": lambda r: [*r[:-1], "oxygen-tank"],
    "nothing": lambda r: [],
}


def test_a_ranking_that_is_not_a_permutation_is_refused(
    wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    ranking = open_ranking(wizard)
    for case, mangle in NOT_PERMUTATIONS.items():
        message = refused(partial(phone.submit_ranking, 1, mangle(ranking)), 422)
        assert message == "The ranking must contain each of the 5 items exactly once.", case
    assert phone.state()["view"] == "ranking"
    assert _count(engine, Event, kind="ranking.submitted") == 0


def test_a_ranking_at_the_wrong_moment_is_refused(wizard: WizardBot, phone: ParticipantBot) -> None:
    wizard.start()
    ranking = list(wizard.interaction(1)["presented_order"])
    assert refused(lambda: phone.submit_ranking(1, ranking), 409) == (
        "The ranking is not open at the moment."
    )
    assert "no interaction 7" in refused(lambda: phone.submit_ranking(7, ranking), 422)
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    phone.submit_ranking(1, ranking)
    again = list(reversed(ranking))
    assert refused(lambda: phone.submit_ranking(1, again), 409) == (
        "Your ranking for this round was already saved."
    )
    assert wizard.refresh()["interactions"][0]["initial_ranking"] == ranking


def test_resubmitting_the_same_id_returns_the_stored_result_once(
    wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    ranking = open_ranking(wizard)
    first = phone.submit_ranking(1, ranking, client_id="phone-id-0001")
    assert first["saved"] is True
    assert first["duplicate"] is False
    assert first["stored"] == {"position": 1, "ranking": ranking}
    wizard.advance(1, "negotiation")  # the phone's retry arrives after the wizard moved on
    replay = phone.submit_ranking(1, list(reversed(ranking)), client_id="phone-id-0001")
    assert replay["duplicate"] is True
    assert replay["stored"] == first["stored"]
    assert replay["saved_at"] == first["saved_at"]
    assert replay["state"]["view"] == "ranked"
    assert _count(engine, Event, kind="ranking.submitted") == 1


def test_a_bad_client_id_or_token_is_refused(wizard: WizardBot, phone: ParticipantBot) -> None:
    ranking = open_ranking(wizard)
    refused(lambda: phone.submit_ranking(1, ranking, client_id="short"), 422)
    refused(lambda: phone.submit_ranking(1, ranking, client_id="has spaces in it"), 422)
    stranger = ParticipantBot(phone.http, "not-a-token")
    assert "not valid" in refused(lambda: stranger.submit_ranking(1, ranking), 404)
    assert "not valid" in refused(stranger.state, 404)


@pytest.fixture
def at_questionnaire(wizard: WizardBot, phone: ParticipantBot) -> dict[str, Any]:
    to_negotiation(wizard, phone)
    wizard.negotiate(1, lambda _s: False)
    wizard.advance(1, "questionnaire")
    state = phone.state()
    assert state["view"] == "questionnaire"
    assert (state["page"], state["pages"]) == (1, 4)
    return state


def _credibility(state: dict[str, Any]) -> dict[str, Any]:
    answers: dict[str, Any] = answers_for(state["questionnaire"], random.Random(1))
    return answers


BAD_ANSWERS: list[tuple[dict[str, Any], str]] = [
    ({"reliable": 0}, "The answer to question 1 must be a whole number from 1 to 7."),
    ({"informed": 8}, "The answer to question 2 must be a whole number from 1 to 7."),
    ({"reliable": True}, "The answer to question 1 must be a whole number from 1 to 7."),
    ({"reliable": "5"}, "The answer to question 1 must be a whole number from 1 to 7."),
    ({"reliable": 2.5}, "The answer to question 1 must be a whole number from 1 to 7."),
    ({"reliable": None}, "Please answer question 1."),
    ({"qualified": ""}, "Please answer question 3."),
    ({"charisma": 4}, "Unknown question(s): charisma."),
]


def test_bad_questionnaire_answers_are_refused(
    at_questionnaire: dict[str, Any], phone: ParticipantBot, engine: Engine
) -> None:
    good = _credibility(at_questionnaire)
    for change, message in BAD_ANSWERS:
        answers = {**good, **change}
        got = refused(partial(phone.submit_questionnaire, 1, "credibility", answers), 422)
        assert got == message, change
    assert _count(engine, QuestionnaireResponse, position=1) == 0
    assert phone.state()["page"] == 1


def test_questionnaires_must_match(
    at_questionnaire: dict[str, Any], phone: ParticipantBot, engine: Engine
) -> None:
    final = {"differences": "None", "comments": "None"}
    assert refused(lambda: phone.submit_questionnaire(1, "final", final), 422) == (
        "These questions do not belong to this part of the study."
    )
    assert refused(lambda: phone.submit_questionnaire(0, "final", final), 409) == (
        "The final questions are not open yet."
    )
    assert refused(lambda: phone.submit_questionnaire(2, "credibility", {}), 409) == (
        "These questions are not open at the moment."
    )
    assert _count(engine, QuestionnaireResponse, position=1) == 0


def test_questionnaire_pages_are_stored_once_and_finish_the_interaction(
    at_questionnaire: dict[str, Any], phone: ParticipantBot, wizard: WizardBot, engine: Engine
) -> None:
    answers = _credibility(at_questionnaire)
    receipt = phone.submit_questionnaire(1, "credibility", answers, client_id="q-credibility-1")
    assert receipt["state"]["page"] == 2
    replay = phone.submit_questionnaire(1, "credibility", answers, client_id="q-credibility-1")
    assert replay["duplicate"] is True
    assert refused(lambda: phone.submit_questionnaire(1, "credibility", answers), 409) == (
        "You have already answered these questions."
    )
    assert _count(engine, QuestionnaireResponse, questionnaire="credibility") == 12
    phone.answer_questionnaires(1, random.Random(2))
    assert phone.state()["view"] == "waiting"
    snapshot = wizard.refresh()
    assert snapshot["interactions"][0]["state"] == "done"
    assert snapshot["interactions"][0]["questionnaires"]["answered"] == [
        "credibility",
        "likeability",
        "trust",
        "experience",
    ]
    with build_sessionmaker(engine)() as db:
        rows = list(
            db.scalars(select(QuestionnaireResponse).where(QuestionnaireResponse.position > 0))
        )
    assert {r.version for r in rows} == {"rau2009-v1"}
    assert all(r.interaction_id is not None and r.position == 1 for r in rows)
    assert sorted(r.value or 0 for r in rows if r.questionnaire == "credibility") == sorted(
        answers.values()
    )


def test_optional_items_are_stored_as_skipped_required_ones_are_refused(
    at_questionnaire: dict[str, Any], phone: ParticipantBot, engine: Engine
) -> None:
    """Open questions are optional by default: a blank answer is stored as skipped (no
    value, no text), never as a default; a rated item stays required."""
    answers = _credibility(at_questionnaire)
    missing = {k: v for k, v in answers.items() if k != "honest"}
    assert refused(lambda: phone.submit_questionnaire(1, "credibility", missing), 422) == (
        "Please answer question 7."
    )
    assert at_questionnaire["questionnaire"]["items"][0]["required"] is True
    phone.submit_questionnaire(1, "credibility", answers)
    for questionnaire in ("likeability", "trust"):
        state = phone.state()["questionnaire"]
        phone.submit_questionnaire(1, questionnaire, answers_for(state, random.Random(3)))
    wording = phone.state()["questionnaire"]
    assert wording["id"] == "experience"
    assert wording["items"][0]["required"] is False
    assert refused(lambda: phone.submit_questionnaire(1, "experience", {"experience": 4}), 422) == (
        "The answer to question 1 must be text."
    )
    phone.submit_questionnaire(1, "experience", {"experience": "   "})
    assert phone.state()["view"] == "waiting"
    with build_sessionmaker(engine)() as db:
        row = db.scalars(
            select(QuestionnaireResponse).where(QuestionnaireResponse.questionnaire == "experience")
        ).one()
    assert (row.skipped, row.value, row.text) == (True, None, None)
    assert _count(engine, QuestionnaireResponse, skipped=True) == 1
