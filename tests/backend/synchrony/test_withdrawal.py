"""A withdrawal takes the synchrony measured with the participant's face along: their own,
and other interactions' whose baseline paired their face (to be computed again)."""

from __future__ import annotations

from pathlib import Path

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import InteractionSynchrony, Recording
from chameleons.backend.synchrony import repository, service
from chameleons.backend.withdrawal.service import withdraw_participant
from tests.backend.synchrony.recorded import recorded_study
from tests.backend.synchrony.test_service import PARAMS


def test_synchrony_derived_from_a_withdrawn_face_goes_with_it(
    db_session: DbSession, tmp_path: Path
) -> None:
    study = recorded_study(db_session, tmp_path, participants=3)
    ids = repository.interactions_of(db_session, study.study_id)
    for interaction_id in ids:
        service.compute(db_session, interaction_id, tmp_path, PARAMS)
    theirs = set(db_session.scalars(select(Recording.id).where(
        Recording.interaction_id.in_(ids[:3]))))  # fmt: skip  # P001's three interactions
    paired = {r.interaction_id for r in repository.stored(db_session, ids[3:]).values()
              if any(set(p) & theirs or set(q) & theirs for p, q in r.surrogates)}  # fmt: skip
    assert paired  # their face was in other interactions' baselines
    result = withdraw_participant(db_session, study.study_id, "P001", "P001", tmp_path)
    left = list(db_session.scalars(select(InteractionSynchrony)))
    assert {r.interaction_id for r in left} == set(ids[3:]) - paired
    for row in left:
        used = set(row.recordings) | {i for pair in row.surrogates for part in pair for i in part}
        assert not used & theirs
    sentence = next(s for s in result.removed if "synchrony" in s)
    assert f"the synchrony of {len(paired)} other interaction" in sentence
