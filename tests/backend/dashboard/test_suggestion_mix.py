"""The dashboard's optimal/random mix of the robot's suggestions per condition, counted
against the rows themselves, with the test that flags a condition getting more random ones."""

from __future__ import annotations

from collections import Counter

from fastapi.testclient import TestClient
from sqlalchemy import Engine, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.dashboard.suggestion_mix import suggestion_mix
from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import Interaction, Study, Suggestion
from tests.backend.test_auth import add_user, login
from tests.support.factories import populate


def _suggestions(db: DbSession) -> list[tuple[str, Suggestion]]:
    query = select(Interaction.condition, Suggestion).join(
        Interaction, Interaction.id == Suggestion.interaction_id
    )
    return [(condition, suggestion) for condition, suggestion in db.execute(query).tuples()]


def test_the_mix_counts_every_suggestion_by_condition_kind_and_direction(
    db_session: DbSession,
) -> None:
    data = populate(db_session, 12)
    # One suggestion of every copy interaction moves down (the best-move rule does that).
    for condition, suggestion in _suggestions(db_session):
        if condition == "copy" and suggestion.index == 1:
            suggestion.from_rank, suggestion.to_rank = 1, 5
    db_session.flush()
    study = db_session.get(Study, data.study_id)
    assert study is not None
    mix = suggestion_mix(db_session, study, data.spec)
    expected = Counter((c, s.kind) for c, s in _suggestions(db_session))
    assert [m.condition for m in mix.conditions] == ["still", "natural", "copy"]
    for row in mix.conditions:
        assert (row.optimal, row.random) == (
            expected[(row.condition, "optimal")], expected[(row.condition, "random")],
        )  # fmt: skip
        assert row.total == 36
        assert row.down == (12 if row.condition == "copy" else 0)
        assert row.random_share == row.random / 36


def test_a_condition_with_more_random_suggestions_is_flagged(db_session: DbSession) -> None:
    data = populate(db_session, 12)
    study = db_session.get(Study, data.study_id)
    assert study is not None
    for condition, suggestion in _suggestions(db_session):
        suggestion.kind = "random" if condition == "still" else "optimal"
    db_session.flush()
    confounded = suggestion_mix(db_session, study, data.spec)
    assert confounded.confounded
    assert confounded.p is not None
    assert confounded.p < 1e-6
    # The same share of random suggestions everywhere: no flag (chi2 = 0, p = 1).
    for _condition, suggestion in _suggestions(db_session):
        suggestion.kind = "random" if suggestion.index == 3 else "optimal"
    db_session.flush()
    even = suggestion_mix(db_session, study, data.spec)
    assert not even.confounded
    assert even.chi2 == 0.0
    # Only one kind at all: the test is undefined, not "no difference".
    for _condition, suggestion in _suggestions(db_session):
        suggestion.kind = "optimal"
    db_session.flush()
    assert suggestion_mix(db_session, study, data.spec).p is None


def test_the_overview_page_shows_the_mix(client: TestClient, engine: Engine) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        populate(db, 6)
    add_user(engine, "pi", "a long password", "pi")
    login(client, "pi", "a long password")
    page = client.get("/pi").text
    assert 'id="suggestion-mix"' in page
    assert 'data-condition="copy"' in page
    assert "Robot suggestions per condition" in page
    mix = client.get("/api/pi/overview").json()["suggestion_mix"]
    assert [row["condition"] for row in mix["conditions"]] == ["still", "natural", "copy"]
    assert sum(row["total"] for row in mix["conditions"]) == 6 * 3 * 3
