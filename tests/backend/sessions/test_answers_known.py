"""Which questionnaires are answered is read from the database only while a part may still
change (``sessions.answers._part``): a part not open yet has no answers, and a closed
part's are kept once a committed state showed it closed (issue 34)."""

from __future__ import annotations

import contextlib
import random
import re
from typing import Any

from fastapi import FastAPI
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker
from chameleons.backend.events.unit_of_work import write_session
from chameleons.backend.sessions import answers, ending
from chameleons.backend.sessions.bot import answers_for
from chameleons.backend.sessions.flow import load
from chameleons.backend.sessions.snapshot import session_snapshot
from tests.backend.sessions.conftest import to_negotiation
from tests.backend.wizard.test_retained_state import statements_here
from tests.support.bots import ParticipantBot, WizardBot

ANSWERS_READ = re.compile(r"^\s*SELECT\b.*\bFROM questionnaire_response\b", re.I | re.DOTALL)
FIRST = "credibility"  # the first of the default study's questionnaires after an interaction


def _snapshot(engine: Engine, session_id: int) -> tuple[dict[str, Any], int]:
    """A console's snapshot read now, and how many times it read the answers."""
    with build_sessionmaker(engine)() as db, statements_here() as statements:
        found = session_snapshot(load(db, session_id, lock=False), "", [])
    return found, len([s for s in statements if ANSWERS_READ.search(s)])


def _answered(snapshot: dict[str, Any], position: int) -> list[str]:
    progress = snapshot["interactions"][position - 1]["questionnaires"]
    assert isinstance(progress["answered"], list)
    return progress["answered"]


def _kept(token: str) -> dict[int, frozenset[str]]:
    return {position: ids for (link, position), ids in answers._CLOSED.items() if link == token}


def _to_questionnaire(wizard: WizardBot, phone: ParticipantBot) -> None:
    to_negotiation(wizard, phone)
    wizard.negotiate(1, lambda _suggestion: True)
    wizard.advance(1, "questionnaire")


def test_answers_are_read_only_while_a_part_may_change(
    wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    phone.prepare(random.Random(1))  # consent and the questions before the session
    assert _snapshot(engine, wizard.session_id)[1] >= 1  # pending: those are still open
    to_negotiation(wizard, phone)  # the start closed them; interaction 1 is not at its own
    snapshot, reads = _snapshot(engine, wizard.session_id)
    assert reads == 0
    assert _answered(snapshot, 1) == []
    assert _kept(wizard.token) == {-1: frozenset({"demographics"})}
    wizard.negotiate(1, lambda _suggestion: True)
    wizard.advance(1, "questionnaire")
    phone.submit_questionnaire(1, FIRST, _answers_to(phone))
    snapshot, reads = _snapshot(engine, wizard.session_id)
    assert reads == 1  # interaction 1's questionnaires are open
    assert _answered(snapshot, 1) == [FIRST]


def _answers_to(phone: ParticipantBot) -> dict[str, Any]:
    state = phone.state()
    assert state["view"] == "questionnaire", state
    assert state["questionnaire"]["id"] == FIRST, state
    found: dict[str, Any] = answers_for(state["questionnaire"], random.Random(2))
    return found


def test_a_closed_parts_answers_are_kept_once_committed(
    app: FastAPI, wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    """Ending the session closes interaction 1's questionnaires; an end that is rolled back
    keeps nothing, so the answers given after it show. Once interaction 1 is done its
    answers are kept, and later snapshots read none."""
    _to_questionnaire(wizard, phone)
    phone.submit_questionnaire(1, FIRST, _answers_to(phone))
    factory = build_sessionmaker(engine)
    with contextlib.suppress(RuntimeError), write_session(factory, app.state.live_hub) as db:
        flow = load(db, wizard.session_id)
        ending.end_early(flow, "other", note="a slip of the wizard's hand")
        assert _answered(session_snapshot(flow, "", []), 1) == [FIRST]
        raise RuntimeError("rolled back")  # e.g. the commit failed
    assert 1 not in _kept(wizard.token)
    phone.answer_questionnaires(1, random.Random(3))  # the rest: interaction 1 is done
    required = wizard.refresh()["interactions"][0]["questionnaires"]["required"]
    assert len(required) > 1
    later, reads = _snapshot(engine, wizard.session_id)
    assert reads == 0  # kept when the refresh above showed it closed
    assert _answered(later, 1) == required
    assert _kept(wizard.token)[1] == frozenset(required)
    kept = answers._CLOSED.copy()
    answers._CLOSED.clear()  # as after a restart: read again, and the same
    try:
        fresh, reads = _snapshot(engine, wizard.session_id)
    finally:
        answers._CLOSED.update(kept)
    assert reads == 1
    assert fresh["interactions"] == later["interactions"]
