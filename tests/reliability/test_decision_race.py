"""Two wizards send opposite decisions on one suggestion at the same moment, 100 times, on
SQLite and PostgreSQL: every time exactly one wins (200) and the other is told why (409
with a sentence); the stored decision, the ranking and the event log agree with the winner.

Real uvicorn server (thread pool: the two requests really run at once), two logged-in
clients, a barrier to release them together. The undo window is widened so each trial can
take its decision back whatever the machine's load.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from fastapi import FastAPI
from sqlalchemy import Engine, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import Event, Interaction, Suggestion
from chameleons.backend.sessions import flow as session_flow
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, staff_api, study_with_plan
from tests.support.live_server import LiveServer

TRIALS = 100
TIMEOUT = httpx.Timeout(120.0)  # generous: a loaded machine is slow, never wrong


@pytest.fixture
def server(app: FastAPI) -> Iterator[LiveServer]:
    with LiveServer(app) as live:
        yield live


def _client(server: LiveServer) -> httpx.Client:
    return httpx.Client(base_url=server.url, timeout=TIMEOUT)


def _pending(wizard: WizardBot) -> int:
    interaction = wizard.refresh()["interactions"][0]
    pending = [s["index"] for s in interaction["suggestions"] if s["accepted"] is None]
    assert len(pending) == 1, interaction["suggestions"]
    return int(pending[0])


def _race(apis: list[StaffApi], session_id: int, index: int) -> list[tuple[bool, int, Any]]:
    barrier = threading.Barrier(len(apis))
    results: list[tuple[bool, int, Any]] = []

    def send(api: StaffApi, accepted: bool) -> None:
        body = {"position": 1, "index": index, "accepted": accepted}
        barrier.wait(timeout=120)
        try:
            response = api.http.post(
                f"/api/sessions/{session_id}/decide",
                json=body,
                headers={"X-CSRF-Token": api.csrf},
            )
            results.append((accepted, response.status_code, response.json()))
        except Exception as exc:  # reported by the assertion, with the trial
            results.append((accepted, -1, repr(exc)))

    threads = [
        threading.Thread(target=send, args=(api, accepted))
        for api, accepted in zip(apis, (True, False), strict=True)
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=300)
    return results


def test_opposite_decisions_at_once_have_exactly_one_winner(
    server: LiveServer, engine: Engine, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(session_flow, "UNDO_WINDOW_SECONDS", 3600.0)
    clients = [_client(server), _client(server), _client(server)]
    try:
        pi = staff_api(clients[0], engine, "pi")
        wizards = [staff_api(c, engine, "wizard", f"wizard-{k}") for k, c in enumerate(clients[1:])]
        wizard = WizardBot.create(pi, study_with_plan(pi))
        phone = ParticipantBot(clients[0], wizard.token)
        wizard.start()
        wizard.advance(1, "discussion")
        wizard.advance(1, "ranking")
        phone.submit_ranking(1, list(wizard.interaction(1)["presented_order"]))
        wizard.advance(1, "negotiation")
        index = _pending(wizard)
        before = list(wizard.interaction(1)["current_ranking"])
        for trial in range(TRIALS):
            results = _race(wizards, wizard.session_id, index)
            codes = sorted(code for _accepted, code, _body in results)
            assert codes == [200, 409], f"trial {trial}: {results}"
            winner = next(accepted for accepted, code, _body in results if code == 200)
            refusal = next(body for _accepted, code, body in results if code == 409)
            assert f"Suggestion {index} of interaction 1 is already" in refusal["detail"]
            _check_stored(engine, wizard.session_id, index, winner)
            wizard.undo(1, index)
            assert wizard.interaction(1)["current_ranking"] == before, f"trial {trial}"
        _check_events(engine, wizard.session_id, TRIALS)
    finally:
        for client in clients:
            client.close()


def _check_stored(engine: Engine, session_id: int, index: int, winner: bool) -> None:
    with DbSession(engine) as db:
        interaction = db.scalars(
            select(Interaction).where(
                Interaction.session_id == session_id, Interaction.position == 1
            )
        ).one()
        suggestions = db.scalars(
            select(Suggestion).where(Suggestion.interaction_id == interaction.id)
        ).all()
        chosen = next(s for s in suggestions if s.index == index)
        assert chosen.accepted is winner
        # One proposal after the decision at most (the next one), never two.
        assert [s.index for s in suggestions if s.index > index] in ([], [index + 1])


def _check_events(engine: Engine, session_id: int, trials: int) -> None:
    with DbSession(engine) as db:
        kinds = db.scalars(
            select(Event.kind)
            .where(
                Event.session_id == session_id,
                Event.kind.in_(("suggestion.decided", "suggestion.undone")),
            )
            .order_by(Event.id)
        ).all()
    assert list(kinds) == ["suggestion.decided", "suggestion.undone"] * trials
