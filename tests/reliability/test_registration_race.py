"""Wizards at several booths register participants for one study at the same moment, on
SQLite and PostgreSQL: every registration gets its own plan row and code (two at once took
the same row: a 500 on ``participant.plan_row_id``'s unique constraint, found by
bench/server_hold.py opening its sessions concurrently).

Real uvicorn server (its thread pool runs the requests at once), one logged-in client per
booth, a barrier to release them together, several rounds."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import httpx
import pytest
from fastapi import FastAPI
from sqlalchemy import Engine, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import Participant
from tests.support.bots import StaffApi, staff_api, study_with_plan
from tests.support.live_server import LiveServer

BOOTHS = 4
ROUNDS = 6
TIMEOUT = httpx.Timeout(120.0)  # generous: a loaded machine is slow, never wrong


@pytest.fixture
def server(app: FastAPI) -> Iterator[LiveServer]:
    with LiveServer(app) as live:
        yield live


def _register_at_once(apis: list[StaffApi], study_id: int, round_: int) -> list[tuple[int, str]]:
    """Each booth's (status, body) of one round."""
    barrier = threading.Barrier(len(apis))
    responses: list[tuple[int, str]] = []

    def register(api: StaffApi, booth: str) -> None:
        barrier.wait(timeout=120)
        body = {"study_id": study_id, "booth": booth}
        response = api.http.post("/api/sessions", json=body, headers={"X-CSRF-Token": api.csrf})
        responses.append((response.status_code, response.text[:200]))

    threads = [
        threading.Thread(target=register, args=(api, f"booth-{round_}-{i}"))
        for i, api in enumerate(apis)
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=300)
    return responses


def test_registrations_at_once_each_get_their_own_plan_row(
    server: LiveServer, engine: Engine
) -> None:
    clients = [httpx.Client(base_url=server.url, timeout=TIMEOUT) for _ in range(BOOTHS)]
    try:
        pi = staff_api(clients[0], engine, "pi")
        study_id = study_with_plan(pi, participants=BOOTHS * ROUNDS)
        apis = [staff_api(c, engine, "wizard", f"wizard-{k}") for k, c in enumerate(clients)]
        for round_ in range(ROUNDS):
            responses = _register_at_once(apis, study_id, round_)
            assert sorted(status for status, _ in responses) == [201] * BOOTHS, responses
    finally:
        for client in clients:
            client.close()
    with DbSession(engine) as db:
        participants = list(db.scalars(select(Participant).where(Participant.study_id == study_id)))
    assert len(participants) == BOOTHS * ROUNDS
    assert len({p.plan_row_id for p in participants}) == BOOTHS * ROUNDS
    assert None not in {p.plan_row_id for p in participants}
    assert len({p.code for p in participants}) == BOOTHS * ROUNDS
