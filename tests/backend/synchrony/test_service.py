"""Synchrony from real recordings in a real database: every interaction gets its values or
a reason, copy interactions measure their delay, the baseline comes from other
participants' faces, and every number traces back to its parameters and pseudo-pairs."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from sqlalchemy import delete, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import Interaction, InteractionSynchrony, Recording
from chameleons.backend.synchrony import repository, service
from chameleons.backend.synchrony.runner import SynchronyRunner
from chameleons.experiment.stats.synchrony import SyncParams
from tests.backend.synchrony.recorded import recorded_study

PARAMS = SyncParams(window_s=20.0, increment_s=10.0, segment_s=20.0, surrogates=12,
                    min_between=6)  # fmt: skip


def computed(db: DbSession, data_dir: Path, study_id: int) -> dict[int, InteractionSynchrony]:
    ids = repository.interactions_of(db, study_id)
    for interaction_id in ids:
        service.compute(db, interaction_id, data_dir, PARAMS)
    return repository.stored(db, ids)


def test_every_recorded_interaction_gets_values_or_a_reason(
    db_session: DbSession, tmp_path: Path
) -> None:
    study = recorded_study(db_session, tmp_path)
    rows = computed(db_session, tmp_path, study.study_id)
    interactions = {i.id: i for i in db_session.scalars(select(Interaction))}
    assert len(rows) == len(interactions) == 12
    by_condition: dict[str, list[InteractionSynchrony]] = {}
    for interaction_id, row in rows.items():
        by_condition.setdefault(interactions[interaction_id].condition, []).append(row)
    for row in by_condition["copy"]:
        assert row.reason is None
        assert row.sync_lag_s == pytest.approx(4.0, abs=0.05)
        assert row.check == "ok"
        assert row.surrogate_kind == "between"
        assert row.sync_band_r is not None
        assert row.sync_r is not None
        assert row.sync_r > row.sync_band_r
        assert row.face_source == "livelink"
        assert row.usable_share is not None
        assert row.usable_share > 0.9
    for row in by_condition["still"]:  # lip-sync moved its jaw: masked, so nothing moved
        assert row.reason == "robot_still"
        assert row.sync_r is None
        assert row.check is None
    for row in by_condition["natural"]:
        assert row.reason is None
        assert row.mimicry_r is not None
        assert row.check is None


def test_a_number_traces_back_to_its_parameters_and_pseudo_pairs(
    db_session: DbSession, tmp_path: Path
) -> None:
    study = recorded_study(db_session, tmp_path)
    rows = computed(db_session, tmp_path, study.study_id)
    copy_id = next(i for i, r in rows.items() if r.check == "ok")
    row = rows[copy_id]
    assert row.params["window_s"] == 20.0
    assert row.params["seed"] == copy_id
    assert row.params["method_version"] == 2
    own = {r.id for r in db_session.scalars(select(Recording).where(
        Recording.interaction_id == copy_id))}  # fmt: skip
    assert set(row.recordings) == own
    assert len(row.surrogates) == row.surrogate_count
    for participant_ids, robot_ids in row.surrogates:
        assert bool(set(participant_ids) & own) != bool(set(robot_ids) & own)  # one is ours
    first = (row.sync_lag_s, row.sync_r, row.mimicry_r, row.surrogates)
    again = service.compute(db_session, copy_id, tmp_path, PARAMS)
    assert again is not None
    assert (again.sync_lag_s, again.sync_r, again.mimicry_r, again.surrogates) == first
    assert len(repository.stored(db_session, [copy_id])) == 1  # replaced, not added


def test_the_first_participant_gets_the_within_interaction_baseline(
    db_session: DbSession, tmp_path: Path
) -> None:
    study = recorded_study(db_session, tmp_path, participants=1)
    rows = computed(db_session, tmp_path, study.study_id)
    kinds = {r.surrogate_kind for r in rows.values() if r.reason is None}
    assert kinds == {"segments"}
    assert all(r.surrogates == [] for r in rows.values())


def test_rehearsals_pair_only_with_rehearsals(db_session: DbSession, tmp_path: Path) -> None:
    study = recorded_study(db_session, tmp_path, participants=1, rehearsals=3)
    rows = computed(db_session, tmp_path, study.study_id)
    real = set(repository.interactions_of(db_session, study.study_id)[:3])
    for interaction_id, row in rows.items():
        if row.reason is not None:
            continue
        expected = "segments" if interaction_id in real else "between"
        assert row.surrogate_kind == expected


def test_an_interaction_without_the_robots_recording_says_so(
    db_session: DbSession, tmp_path: Path
) -> None:
    study = recorded_study(db_session, tmp_path, participants=1)
    first = repository.interactions_of(db_session, study.study_id)[0]
    db_session.execute(delete(Recording).where(Recording.interaction_id == first,
                                               Recording.stream == "agent"))  # fmt: skip
    row = service.compute(db_session, first, tmp_path, PARAMS)
    assert row is not None
    assert row.reason == "no_recording"
    assert row.detail == "No face recording of the robot."


def test_the_runner_computes_in_its_own_thread_and_commits(
    db_session: DbSession, tmp_path: Path, engine: object
) -> None:
    from chameleons.backend.db import build_sessionmaker

    study = recorded_study(db_session, tmp_path, participants=1)
    db_session.commit()
    ids = repository.interactions_of(db_session, study.study_id)
    runner = SynchronyRunner(build_sessionmaker(engine), tmp_path, PARAMS)  # type: ignore[arg-type]
    futures = [runner.submit(i) for i in ids]
    asyncio.run(runner.settled())
    assert all(f.done() for f in futures)
    assert runner.computed == len(ids)
    assert runner.failed == 0
    db_session.expire_all()
    assert set(repository.stored(db_session, ids)) == set(ids)
    asyncio.run(runner.stop(1.0))
