"""A repeated visit of the analysis page with the data unchanged is served from the cache
without reading the rows; any change of the data (here an exclusion and its undoing, and
a participant's new session) is a new data version, so the page is never stale
(chameleons.backend.analysis.repository)."""

from __future__ import annotations

from sqlalchemy import Engine
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.analysis.cache import analyses
from chameleons.backend.analysis.repository import data_version
from chameleons.backend.analysis.service import study_analysis
from chameleons.backend.db import build_sessionmaker
from chameleons.backend.dropouts import service as dropouts
from chameleons.backend.models import Participant
from tests.backend.wizard.test_retained_state import statements_here
from tests.support.factories import populate


def _participants(engine: Engine) -> list[str]:
    with build_sessionmaker(engine)() as db:
        result = study_analysis(db, extended=False)
        assert result.analysis is not None, result.error
        return sorted(result.analysis.participants)


def test_a_repeated_visit_reads_no_rows(db_session: DbSession, engine: Engine) -> None:
    populate(db_session, 12, seed=3)
    db_session.commit()
    analyses.clear()
    first = _participants(engine)
    with build_sessionmaker(engine)() as db, statements_here() as statements:
        again = study_analysis(db, extended=False)
    assert again.analysis is not None
    assert sorted(again.analysis.participants) == first
    # The study and the data version; no row of a session.
    assert len(statements) == 2, statements
    assert again.scores.study.name  # this request's study row, usable after the cache


def test_every_change_is_a_new_version(db_session: DbSession, engine: Engine) -> None:
    data = populate(db_session, 12, seed=3)
    db_session.commit()
    before = _participants(engine)
    version = data_version(db_session)
    code = before[0]

    dropouts.exclude(db_session, data.study_id, code, "fell asleep")
    db_session.commit()
    assert data_version(db_session) != version
    assert code not in _participants(engine)

    dropouts.include(db_session, data.study_id, code)
    db_session.commit()
    assert _participants(engine) == before


def test_rows_written_without_an_event_are_a_new_version(
    db_session: DbSession, engine: Engine
) -> None:
    """A participant a script adds straight into the table (no event) moves the version."""
    data = populate(db_session, 6, seed=4)
    db_session.commit()
    version = data_version(db_session)
    db_session.add(Participant(study_id=data.study_id, code="P900", status="registered"))
    db_session.commit()
    assert data_version(db_session) != version
