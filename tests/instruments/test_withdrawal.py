"""Withdrawing a participant deletes what the other instruments recorded of them: the
imported streams' rows and Parquet files, and the coders' annotations."""

from __future__ import annotations

from pathlib import Path

import pytest
from sqlalchemy import func, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.instruments.xdf_import import import_xdf
from chameleons.backend.models import CodedAnnotation, InstrumentStream, Participant, Session
from chameleons.backend.withdrawal.service import withdraw_participant
from tests.instruments.xdf_session import recorded_session


@pytest.mark.slow
def test_withdrawal_deletes_the_instrument_streams_and_codes(
    db_session: DbSession, tmp_path: Path
) -> None:
    data = tmp_path / "data"
    recorded = recorded_session(db_session, tmp_path)
    result = import_xdf(db_session, recorded.session_id, recorded.path, data)
    files = [data / row.path for row in result.streams]
    db_session.add(
        CodedAnnotation(
            session_id=recorded.session_id,
            coder="A",
            tier="prompts",
            start_ms=0,
            end_ms=10,
            value="x",
            source_file="a.eaf",
        )
    )
    db_session.commit()
    assert all(path.is_file() for path in files)
    session = db_session.get(Session, recorded.session_id)
    assert session is not None
    participant = db_session.get(Participant, session.participant_id)
    assert participant is not None
    withdrawn = withdraw_participant(db_session, session.study_id, participant.code,
                                     participant.code, data)  # fmt: skip
    db_session.commit()
    assert not any(path.exists() for path in files)
    assert not (data / "instruments" / f"session-{recorded.session_id}").exists()
    assert db_session.scalar(select(func.count()).select_from(InstrumentStream)) == 0
    assert db_session.scalar(select(func.count()).select_from(CodedAnnotation)) == 0
    assert "2 files of other instruments (streams attached with import-xdf)" in withdrawn.removed
