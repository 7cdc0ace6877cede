"""A logged-in wizard, the default study with a plan, a fresh session and its phone."""

from __future__ import annotations

import gc
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from tests.support.bots import ParticipantBot, StaffApi, WizardBot, staff_api, study_with_plan


@pytest.fixture
def pi(client: TestClient, engine: Engine) -> StaffApi:
    return staff_api(client, engine, "pi")


@pytest.fixture
def wizard(pi: StaffApi) -> WizardBot:
    return WizardBot.create(pi, study_with_plan(pi, participants=2))


@pytest.fixture
def phone(client: TestClient, wizard: WizardBot) -> ParticipantBot:
    return ParticipantBot(client, wizard.token)


def api(wizard: WizardBot) -> str:
    return f"/api/wizard/sessions/{wizard.session_id}"


def to_negotiation(wizard: WizardBot, phone: ParticipantBot) -> list[str]:
    """Interaction 1 up to negotiation, ranked in the presented order."""
    wizard.start()
    wizard.advance(1, "discussion")
    wizard.advance(1, "ranking")
    ranking = list(wizard.interaction(1)["presented_order"])
    phone.submit_ranking(1, ranking)
    wizard.advance(1, "negotiation")
    return ranking


@pytest.fixture(autouse=True)
def _collect_after() -> Iterator[None]:
    """Collect garbage after each test, so a leaked database connection is reported against
    the test that leaked it rather than a later one."""
    yield
    gc.collect()
