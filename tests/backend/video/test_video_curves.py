"""The replay's faces: the session's face recordings, on the worker's clock, placed on the
session's clock through the events that carry both, a few samples a second."""

from __future__ import annotations

import itertools
from datetime import UTC
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import Event, Interaction, Recording, Session
from chameleons.backend.video.curves import RATE_HZ, session_curves, worker_offset
from tests.support.factories import populate


def test_the_faces_land_on_the_session_clock(db_session: DbSession, tmp_path: Path) -> None:
    study = populate(db_session, participants=1, recordings_dir=tmp_path / "recordings")
    session_id = study.session_ids[0]
    session = db_session.get(Session, session_id)
    assert session is not None
    assert session.started_at is not None
    first = db_session.scalars(select(Interaction).where(Interaction.session_id == session_id)
                               .order_by(Interaction.position)).first()  # fmt: skip
    assert first is not None
    # The worker's clock reads the server's epoch minus K: every event it reported says so.
    k = 1_772_000_000.0
    reported = select(Event).where(Event.session_id == session_id, Event.worker_time.is_not(None))
    for event in db_session.scalars(reported):
        stamp = event.server_time
        event.worker_time = (stamp if stamp.tzinfo else stamp.replace(tzinfo=UTC)).timestamp() - k
    db_session.flush()
    offset = worker_offset(db_session, session_id)
    assert offset is not None
    assert abs(offset - k) < 1e-3
    origin = session.started_at.replace(tzinfo=UTC)
    at = origin.timestamp() + 30.0 - k  # worker time 30 s into the session
    # The first interaction's streams replaced by known ones from 30 s into the session:
    # the participant's jawOpen 0.25 for a second, then 0.75; the robot's 0.5.
    times = [at + n / 50 for n in range(100)]
    for stream, jaw in (("participant", [0.25 if t < at + 1.0 else 0.75 for t in times]),
                        ("agent", [0.5] * 100)):  # fmt: skip
        recording = db_session.scalars(select(Recording).where(
            Recording.interaction_id == first.id, Recording.stream == stream)).one()  # fmt: skip
        pq.write_table(pa.table({"capture_time": times, "jawOpen": jaw,
                                 "mouthSmileLeft": [0.2] * 100, "mouthSmileRight": [0.4] * 100}),
                       recording.path)  # fmt: skip
    db_session.flush()
    faces = session_curves(db_session, session_id, tmp_path, origin)
    assert faces["reason"] == ""
    participant, robot = faces["streams"]["participant"], faces["streams"]["robot"]
    assert set(robot["jaw open"]) == {0.5}  # the robot's face, on the same clock
    zero = 30.0
    t = participant["t"]
    near = [k for k, x in enumerate(t) if zero + 0.3 < x < zero + 0.7]
    later = [k for k, x in enumerate(t) if zero + 1.3 < x < zero + 1.7]
    assert near
    assert later
    assert {participant["jaw open"][k] for k in near} == {0.25}
    assert {participant["jaw open"][k] for k in later} == {0.75}
    assert {participant["smile"][k] for k in near} == {0.3}  # the mean of left and right
    assert all(b - a >= 1 / RATE_HZ - 1e-6 for a, b in itertools.pairwise(t))
    assert participant["brows up"][near[0]] is None  # a channel the file lacks


def test_faces_without_a_worker_clock_are_not_placed(db_session: DbSession, tmp_path: Path) -> None:
    study = populate(db_session, participants=1, recordings_dir=tmp_path / "recordings")
    session_id = study.session_ids[0]
    for event in db_session.scalars(select(Event).where(Event.session_id == session_id)):
        event.worker_time = None
    db_session.flush()
    session = db_session.get(Session, session_id)
    assert session is not None
    assert session.started_at is not None
    faces = session_curves(db_session, session_id, tmp_path, session.started_at)
    assert faces["streams"] == {}
    assert "cannot be placed on the timeline" in faces["reason"]
