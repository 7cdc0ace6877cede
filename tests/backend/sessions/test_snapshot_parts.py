"""The console's snapshot built with less work (issue 34) still says what the study and
the database say: each interaction's items, names and expert order are its own study's
(kept per study config and presented order), and the suggestions are read only once an
interaction can have any, once per change, and no more once the interaction is settled
(kept after the commit that settled it, never before)."""

from __future__ import annotations

import contextlib
import re
from collections.abc import Callable
from functools import partial
from typing import Any

from fastapi import FastAPI
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker
from chameleons.backend.events.unit_of_work import write_session
from chameleons.backend.sessions import negotiation, service, snapshot
from chameleons.backend.sessions.flow import Flow, allowed_actions, load
from chameleons.backend.sessions.snapshot import session_snapshot
from chameleons.backend.studies.specs import item_key
from chameleons.experiment.study import default_study_path
from tests.backend.sessions.conftest import open_ranking, to_negotiation
from tests.backend.wizard.test_retained_state import statements_here
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, study_with_plan

SUGGESTION_READ = re.compile(r"^\s*SELECT\b.*\bFROM suggestion\b", re.IGNORECASE | re.DOTALL)


def _snapshot(engine: Engine, session_id: int) -> tuple[dict[str, Any], list[str]]:
    with build_sessionmaker(engine)() as db, statements_here() as statements:
        flow = load(db, session_id, lock=False)
        return session_snapshot(flow, "", []), statements


def _expected_items(engine: Engine, session_id: int) -> list[list[tuple[str, str, int]]]:
    """Each interaction's items as the study's spec gives them, in presented order."""
    with build_sessionmaker(engine)() as db:
        flow = load(db, session_id, lock=False)
        found = []
        for interaction in flow.interactions:
            task = flow.spec.task(interaction.task)
            items = [task.item(item_key(str(i))) for i in interaction.presented_order]
            order = interaction.presented_order
            found.append([(str(i), item.name, item.expert_rank)
                          for i, item in zip(order, items, strict=True)])  # fmt: skip
        return found


def _shown_items(snapshot: dict[str, Any]) -> list[list[tuple[str, str, int]]]:
    interactions = snapshot["interactions"]
    assert isinstance(interactions, list)
    return [[(item["id"], item["name"], item["expert_rank"]) for item in i["items"]]
            for i in interactions]  # fmt: skip


def test_two_studies_with_the_same_plan_show_their_own_items(pi: StaffApi, engine: Engine) -> None:
    renamed = re.sub(r'(\n\s+en: ")', r"\1Renamed ", default_study_path().read_text())
    first = WizardBot.create(pi, study_with_plan(pi, seed=7))
    second = WizardBot.create(pi, study_with_plan(pi, seed=7, yaml=renamed))
    orders = [[i["presented_order"] for i in w.snapshot["interactions"]] for w in (first, second)]
    assert orders[0] == orders[1]  # the same plan: only the study's config tells them apart
    for wizard in (first, second, first, second):  # built, then kept
        snapshot, _ = _snapshot(engine, wizard.session_id)
        assert _shown_items(snapshot) == _expected_items(engine, wizard.session_id)
        interactions = snapshot["interactions"]
        assert isinstance(interactions, list)
        for interaction in interactions:
            ranks = {item["id"]: item["expert_rank"] for item in interaction["items"]}
            assert interaction["expert_order"] == sorted(ranks, key=ranks.__getitem__)
    names = [_shown_items(_snapshot(engine, w.session_id)[0])[0][0][1] for w in (first, second)]
    assert names[1] == f"Renamed {names[0]}"


def test_suggestions_are_read_once_an_interaction_can_have_any(
    app: FastAPI, wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    ranking = open_ranking(wizard)
    snapshot, statements = _snapshot(engine, wizard.session_id)
    assert not [s for s in statements if SUGGESTION_READ.search(s)], statements
    assert all(i["suggestions"] == [] for i in snapshot["interactions"])
    phone.submit_ranking(1, ranking)
    wizard.advance(1, "negotiation")  # the robot proposes its first suggestion
    snapshot, statements = _snapshot(engine, wizard.session_id)
    assert [s for s in statements if SUGGESTION_READ.search(s)]
    first = snapshot["interactions"][0]
    assert [s["index"] for s in first["suggestions"]] == [1]
    assert first["suggestions"] == wizard.refresh()["interactions"][0]["suggestions"]


def _suggestions_shown(snapshot: dict[str, Any]) -> list[list[tuple[int, bool | None]]]:
    return [[(s["index"], s["accepted"]) for s in i["suggestions"]]
            for i in snapshot["interactions"]]  # fmt: skip


def test_a_decision_and_an_undo_read_the_suggestions_once(
    app: FastAPI, wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    """The flow keeps the suggestions it read (a decision asked four times) and the
    negotiation keeps that current: the one it proposes is added, the ones an undo
    withdraws are gone, in the snapshot and the buttons alike."""
    to_negotiation(wizard, phone)
    changes: list[Callable[[Flow], object]] = [
        partial(negotiation.decide, position=1, index=1, accepted=True),
        partial(negotiation.undo, position=1, index=1),
    ]
    expected = [[[(1, True), (2, None)], [], []], [[(1, None)], [], []]]
    for change, shown in zip(changes, expected, strict=True):
        with build_sessionmaker(engine)() as db, statements_here() as statements:
            flow = load(db, wizard.session_id)
            change(flow)
            snapshot = session_snapshot(flow, "", [])
            actions = allowed_actions(flow)
            db.commit()
        assert len([s for s in statements if SUGGESTION_READ.search(s)]) == 1, statements
        assert _suggestions_shown(snapshot) == shown
        assert _suggestions_shown(_snapshot(engine, wizard.session_id)[0]) == shown
        assert actions[0] == {"action": "decide", "position": 1, "index": shown[0][-1][0]}


def _settled_kept(token: str) -> list[Any]:
    return [parts for (link, _id), parts in snapshot._SETTLED.items() if link == token]


def test_a_settled_interactions_suggestions_are_kept_once_committed(
    app: FastAPI, wizard: WizardBot, phone: ParticipantBot, engine: Engine
) -> None:
    """Past its negotiation an interaction's suggestions are final, so its shown parts are
    kept and later snapshots read no suggestion. An advance to the questionnaire that is
    rolled back keeps nothing: the negotiation goes on, and the undo after it shows."""
    to_negotiation(wizard, phone)
    wizard.negotiate(1, lambda _suggestion: True)
    factory = build_sessionmaker(engine)
    with contextlib.suppress(RuntimeError), write_session(factory, app.state.live_hub) as db:
        flow = load(db, wizard.session_id)
        service.advance(flow, 1, "questionnaire")
        assert _suggestions_shown(session_snapshot(flow, "", []))[0][-1] == (3, True)
        raise RuntimeError("rolled back")  # e.g. the commit failed
    assert _settled_kept(wizard.token) == []
    wizard.undo(1, 3)
    wizard.decide(1, 3, False)  # the last decision taken back and made the other way
    shown = _suggestions_shown(wizard.advance(1, "questionnaire"))
    assert shown[0] == [(1, True), (2, True), (3, False)]
    assert len(_settled_kept(wizard.token)) == 1  # kept after the advance's commit
    later, statements = _snapshot(engine, wizard.session_id)
    assert not [s for s in statements if SUGGESTION_READ.search(s)], statements
    assert _suggestions_shown(later) == shown
    assert later["interactions"][0]["accepted"] == 2
    kept = snapshot._SETTLED.copy()
    snapshot._SETTLED.clear()  # as after a restart: read again, and the same
    try:
        fresh, statements = _snapshot(engine, wizard.session_id)
    finally:
        snapshot._SETTLED.update(kept)
    assert [s for s in statements if SUGGESTION_READ.search(s)]
    assert fresh["interactions"] == later["interactions"]
