"""A logged-in PI, the default study with a 12-row plan, a fresh session and its phone."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from tests.support.bots import (
    ApiError,
    ParticipantBot,
    StaffApi,
    WizardBot,
    staff_api,
    study_with_plan,
)


@pytest.fixture
def pi(client: TestClient, engine: Engine) -> StaffApi:
    return staff_api(client, engine, "pi")


@pytest.fixture
def study_id(pi: StaffApi) -> int:
    return study_with_plan(pi)


@pytest.fixture
def wizard(pi: StaffApi, study_id: int) -> WizardBot:
    return WizardBot.create(pi, study_id)


@pytest.fixture
def phone(client: TestClient, wizard: WizardBot) -> ParticipantBot:
    return ParticipantBot(client, wizard.token)


def refused(call: Callable[[], Any], status: int) -> str:
    """Run ``call``, expect an API error with ``status``; return its message."""
    with pytest.raises(ApiError) as caught:
        call()
    assert caught.value.status == status, caught.value.detail
    return str(caught.value.detail)


def open_ranking(wizard: WizardBot) -> list[str]:
    """Start the session and open interaction 1's ranking; its presented order."""
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    return list(wizard.interaction(1)["presented_order"])


def to_negotiation(wizard: WizardBot, phone: ParticipantBot, position: int = 1) -> list[str]:
    """Run the interaction up to negotiation with the presented order as the ranking."""
    if wizard.snapshot["state"] == "pending":
        wizard.start()
    wizard.advance(position, "discussion")
    wizard.advance(position, "ranking")
    ranking = list(wizard.interaction(position)["presented_order"])
    phone.submit_ranking(position, ranking)
    wizard.advance(position, "negotiation")
    return ranking
