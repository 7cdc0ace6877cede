"""Data-quality flags, plan progress and the live balance, on both databases."""

from __future__ import annotations

from pathlib import Path

from sqlalchemy import delete, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.dashboard.flags import LATENCY_LIMIT_MS, session_flags
from chameleons.backend.dashboard.progress import live_balance, plan_progress
from chameleons.backend.models import (
    Interaction,
    Participant,
    PlanRow,
    QuestionnaireResponse,
    Session,
    Study,
)
from chameleons.backend.withdrawal.service import withdraw_participant
from tests.support.factories import add_event, populate


def _flags(db: DbSession) -> dict[str, list[str]]:
    study = db.scalars(select(Study)).one()
    from chameleons.experiment.study import study_from_config

    sessions = list(db.scalars(select(Session).order_by(Session.id)))
    codes = {p.id: p.code for p in db.scalars(select(Participant))}
    flags = session_flags(db, study_from_config(study.config), sessions)
    return {codes[s.participant_id]: [f.kind for f in flags[s.id].flags] for s in sessions}


def test_clean_sessions_have_no_flags(db_session: DbSession) -> None:
    populate(db_session, 3)
    assert _flags(db_session) == {"P001": [], "P002": [], "P003": []}


def test_each_kind_of_problem_is_flagged(db_session: DbSession) -> None:
    data = populate(db_session, 7)
    first, second, third, fourth, fifth, sixth, seventh = data.session_ids
    db_session.execute(
        delete(QuestionnaireResponse).where(
            QuestionnaireResponse.session_id == first,
            QuestionnaireResponse.position == 2,
            QuestionnaireResponse.item == "warm",
        )
    )
    switched = db_session.scalars(
        select(Interaction).where(Interaction.session_id == second, Interaction.position == 3)
    ).one()
    switched.condition = next(c for c in ("still", "copy") if c != switched.planned_condition)
    add_event(db_session, third, "worker.outage", {"reason": "process died"}, position=1)
    add_event(db_session, fourth, "prompt.played", {"ack_latency_ms": LATENCY_LIMIT_MS + 900}, 2)
    add_event(db_session, fifth, "plan.deviation", {"field": "condition"}, position=1)
    add_event(db_session, sixth, "prompt.not_sent", {"reason": "worker unreachable"}, 3)
    add_event(db_session, sixth, "prompt.acked", {"click_to_ack_ms": 5200.0}, 3)
    add_event(db_session, seventh, "phone.disconnected", {}, 1)
    add_event(db_session, seventh, "prompt.acked", {"click_to_ack_ms": 120.0}, 1)
    db_session.flush()
    assert _flags(db_session) == {
        "P001": ["missing_answers"],
        "P002": ["deviation"],
        "P003": ["outage"],
        "P004": ["latency"],
        "P005": ["deviation"],
        "P006": ["outage", "latency"],
        "P007": [],
    }


def test_progress_counts_withdrawals_and_replacements(
    db_session: DbSession, tmp_path: Path
) -> None:
    data = populate(db_session, 4, free_rows=2, rehearsals=1)
    study = db_session.get(Study, data.study_id)
    assert study is not None
    before = plan_progress(db_session, study)
    assert (before.rows, before.used, before.free, before.withdrawn) == (7, 4, 3, 0)
    assert before.rehearsal_participants == 1
    assert before.completed_sessions == 4
    result = withdraw_participant(db_session, study.id, "P002", "P002", tmp_path)
    freed = plan_progress(db_session, study)
    assert (freed.used, freed.free, freed.withdrawn, freed.replaced) == (3, 4, 1, 0)
    assert result.plan_row_number == 2
    freed_row = db_session.scalars(
        select(PlanRow).where(PlanRow.study_id == study.id, PlanRow.row_number == 2)
    ).one()
    db_session.add(Participant(study_id=study.id, code="P005", plan_row_id=freed_row.id))
    db_session.flush()
    replaced = plan_progress(db_session, study)
    assert (replaced.used, replaced.replaced, replaced.withdrawn) == (4, 1, 1)


def test_balance_as_run_follows_the_plan_until_a_switch(db_session: DbSession) -> None:
    data = populate(db_session, 12, rehearsals=2)
    study = db_session.get(Study, data.study_id)
    assert study is not None
    report, tables = live_balance(db_session, study, data.spec)
    assert report.participants == 12
    assert report.ok, report.problems()
    assert not any(table.differs_from_plan for table in tables)
    with_rehearsals, _ = live_balance(db_session, study, data.spec, include_rehearsal=True)
    assert with_rehearsals.participants == 14
    switched = db_session.scalars(
        select(Interaction).where(Interaction.session_id == data.session_ids[0])
    ).first()
    assert switched is not None
    switched.condition = next(c for c in data.spec.condition_ids if c != switched.condition)
    db_session.flush()
    _, tables = live_balance(db_session, study, data.spec)
    by_id = {table.id: table for table in tables}
    assert by_id["condition_position"].differs_from_plan
    assert not by_id["face"].differs_from_plan
    cells = {cell.name: cell for cell in by_id["condition_position"].cells}
    changed = [cell for cell in cells.values() if cell.actual != cell.planned]
    assert len(changed) == 2


def test_unstarted_sessions_and_unvoiced_prompts_are_flagged(db_session: DbSession) -> None:
    data = populate(db_session, 2)
    add_event(
        db_session,
        data.session_ids[0],
        "prompt.speech_end",
        {"prompt_id": "intro_nova", "reason": "autoplay_blocked", "detail": "needs a click"},
        position=1,
    )
    add_event(db_session, data.session_ids[1], "prompt.speech_end", {"prompt_id": "x"}, 1)
    session = db_session.get(Session, data.session_ids[1])
    assert session is not None
    session.state = "pending"  # as if registered and never started
    db_session.flush()
    flags = _flags(db_session)
    assert flags == {"P001": ["not_voiced"], "P002": ["not_started"]}
    study = db_session.scalars(select(Study)).one()
    from chameleons.experiment.study import study_from_config

    texts = session_flags(db_session, study_from_config(study.config), [session])
    assert texts[session.id].flags[0].text == "registered; the session was never started"
