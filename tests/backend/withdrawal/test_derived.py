"""Withdrawal also removes what was derived from the participant: another participant's
recording of the robot replaying their face (yoked natural), events quoting them, cached
analyses; on SQLite the database file no longer holds their rows' bytes."""

from __future__ import annotations

from pathlib import Path

import pytest
from sqlalchemy import Engine, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.analysis.cache import analyses
from chameleons.backend.booth.behaviour import describe_source
from chameleons.backend.db import build_sessionmaker
from chameleons.backend.models import Event, Interaction, Recording, Session
from chameleons.backend.withdrawal.derived import REDACTED, SOURCE_WITHDRAWN
from chameleons.backend.withdrawal.endpoints import withdraw_and_scrub
from chameleons.backend.withdrawal.service import withdraw_participant
from tests.backend.withdrawal.test_withdrawal import all_rows, text_of
from tests.support.factories import PopulatedStudy, add_event, populate


def interaction_of(db: DbSession, session_id: int, position: int) -> Interaction:
    return db.scalars(
        select(Interaction).where(
            Interaction.session_id == session_id, Interaction.position == position
        )
    ).one()


def yoke(db: DbSession, data: PopulatedStudy, source_code: str, replayer: int) -> Interaction:
    """Interaction 3 of participant number ``replayer`` ran natural, replaying interaction
    1's participant stream of ``source_code`` (as the booth flow logs it)."""
    source_session = data.session_ids[data.codes.index(source_code)]
    source = interaction_of(db, source_session, 1)
    recording = db.scalars(
        select(Recording).where(
            Recording.interaction_id == source.id, Recording.stream == "participant"
        )
    ).one()
    target = interaction_of(db, data.session_ids[replayer - 1], 3)
    payload = {
        "source": "yoked", "path": f"data:{recording.path}", "recording_id": recording.id,
        "from_interaction_id": source.id, "from_participant": source_code,
        "from_position": 1, "from_condition": source.condition, "frames": 60,
    }  # fmt: skip
    target.natural_source = "yoked"
    target.natural_recording = describe_source(payload)
    session_id = data.session_ids[replayer - 1]
    add_event(db, session_id, "behaviour.natural_source", payload, position=3)
    add_event(db, session_id, "robot.applied", {"natural_source": payload}, position=3)
    add_event(db, session_id, "prompt.played", {"group": "ack_yes"}, position=3)
    db.commit()
    return target


def test_the_robot_replaying_their_face_is_removed_too(
    db_session: DbSession, tmp_path: Path
) -> None:
    data_dir = tmp_path / "data"
    data = populate(db_session, 3, recordings_dir=data_dir / "recordings")
    target = yoke(db_session, data, "P001", replayer=3)
    replay = db_session.scalars(
        select(Recording).where(Recording.interaction_id == target.id)
    ).all()
    agent = next(Path(r.path) for r in replay if r.stream == "agent")
    own = next(Path(r.path) for r in replay if r.stream == "participant")
    assert agent.exists()
    assert "P001" in text_of(all_rows(db_session))

    result = withdraw_participant(db_session, data.study_id, "P001", "P001", data_dir)
    db_session.commit()

    assert "P001" not in text_of(all_rows(db_session))
    assert not agent.exists(), "the robot's replay of P001's face is still on disk"
    assert own.exists(), "P003's own face recording must stay"
    streams = db_session.scalars(
        select(Recording.stream).where(Recording.interaction_id == target.id)
    ).all()
    assert streams == ["participant"]
    db_session.refresh(target)
    assert target.natural_source == "yoked"
    assert target.natural_recording == SOURCE_WITHDRAWN
    events = db_session.scalars(select(Event).where(Event.interaction_id == target.id)).all()
    by_kind = {e.kind: e.payload for e in events}
    assert by_kind["behaviour.natural_source"] == REDACTED
    assert by_kind["robot.applied"] == REDACTED
    assert by_kind["prompt.played"] == {"group": "ack_yes"}, "unrelated events keep content"
    assert any("the robot's recording in P003's interaction 3" in s for s in result.removed)
    assert any("2 events of other sessions" in s for s in result.removed)


def test_cached_analyses_are_dropped(db_session: DbSession, tmp_path: Path) -> None:
    data = populate(db_session, 2)
    db_session.commit()
    analyses.put(("a study", "P001's rows"), {"mean": 3.0})
    result = withdraw_participant(db_session, data.study_id, "P001", "P001", tmp_path)
    assert analyses.get(("a study", "P001's rows")) is None
    assert "the analysis page's cached results" in result.removed


def database_bytes(url: str) -> bytes:
    path = Path(url.removeprefix("sqlite:///"))
    files = [path, path.with_name(path.name + "-wal")]
    return b"".join(p.read_bytes() for p in files if p.exists())


def test_the_sqlite_file_no_longer_holds_their_rows(
    database_url: str, engine: Engine, tmp_path: Path
) -> None:
    if not database_url.startswith("sqlite"):
        pytest.skip("the SQLite file's bytes (PostgreSQL: see docs/science.md)")
    factory = build_sessionmaker(engine)
    with factory() as db:
        data = populate(db, 3)
        db.commit()
        code_rows = db.scalars(select(Session.short_code).where(Session.id == data.session_ids[1]))
        short_code = code_rows.one().encode()
    answer = b"Answer to"  # free-text answers: "Answer to <item> by P002, ..."
    assert b"by P002" in database_bytes(database_url)
    assert short_code in database_bytes(database_url)
    with factory() as db:
        result = withdraw_and_scrub(db, data.study_id, "P002", "P002", tmp_path)
    raw = database_bytes(database_url)
    assert b"by P002" not in raw
    assert short_code not in raw
    assert b"token-" + str(data.study_id).encode() + b"-P002" not in raw
    assert answer + b" " in raw, "the other participants' answers are still there"
    assert any("overwritten with zeros" in s for s in result.removed)
    assert any("write-ahead log (emptied)" in s for s in result.removed)
    assert any("Backups" in s for s in result.kept)


def test_postgres_says_what_it_keeps(database_url: str, engine: Engine, tmp_path: Path) -> None:
    if database_url.startswith("sqlite"):
        pytest.skip("PostgreSQL's report")
    factory = build_sessionmaker(engine)
    with factory() as db:
        data = populate(db, 2)
        db.commit()
    with factory() as db:
        result = withdraw_and_scrub(db, data.study_id, "P002", "P002", tmp_path)
    assert any("VACUUM" in s for s in result.kept)
    assert not any("overwritten" in s for s in result.removed)
