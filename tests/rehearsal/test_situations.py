"""`chameleons rehearse --drop-out RATE --deviate RATE`: dropouts (never started, ended
early with a reason) and confirmed repeated-condition deviations on demand, seeded; the
dashboard flags them and the analysis runs in both views, leaving out whom it must."""

from __future__ import annotations

import secrets
from collections import Counter
from pathlib import Path

import pytest
from click.testing import CliRunner
from sqlalchemy import select

from chameleons.backend.analysis.service import study_analysis
from chameleons.backend.dashboard.sessions import session_summaries
from chameleons.backend.db import build_engine, build_sessionmaker
from chameleons.backend.models import Event, Session, Study
from chameleons.cli.main import cli
from chameleons.experiment.study import study_from_config
from chameleons.rehearsal.embedded import embedded_system
from chameleons.rehearsal.runner import Options, rehearse
from chameleons.rehearsal.situations import NONE, Situation, draw, situations_rng
from chameleons.settings import Settings

INTERACTIONS = 3


def plan(seed: int, n: int, drop_out: float, deviate: float) -> list[Situation]:
    rng = situations_rng(seed)
    return [draw(rng, drop_out, deviate, INTERACTIONS) for _ in range(n)]


def test_no_rates_no_situations() -> None:
    assert plan(3, 50, 0.0, 0.0) == [NONE] * 50


def test_situations_are_seeded_and_follow_the_rates() -> None:
    assert plan(7, 40, 0.3, 0.2) == plan(7, 40, 0.3, 0.2)
    assert plan(7, 40, 0.3, 0.2) != plan(8, 40, 0.3, 0.2)
    many = plan(1, 2000, 0.3, 0.0)
    dropped = [s for s in many if s.stop_at is not None]
    assert 0.25 < len(dropped) / len(many) < 0.35
    assert {s.stop_at for s in dropped} == {0, 1, 2, 3}
    assert {s.reason for s in dropped} == {"participant_withdrew", "technical_failure", "time"}
    everyone = plan(1, 300, 0.0, 1.0)
    assert all(s.deviate_at in (2, 3) for s in everyone)
    assert all(1 <= s.repeat_from < (s.deviate_at or 0) for s in everyone)
    # Raising the deviation rate does not reshuffle who drops out.
    stops = [s.stop_at for s in plan(1, 300, 0.3, 0.0)]
    assert stops == [s.stop_at for s in plan(1, 300, 0.3, 0.9)]


def test_a_deviation_only_where_an_interaction_runs() -> None:
    for situation in plan(2, 500, 1.0, 1.0):
        if situation.deviate_at is not None:
            assert situation.stop_at is None or situation.deviate_at <= situation.stop_at
        else:
            assert situation.stop_at in (0, 1)


def test_the_cli_refuses_a_rate_outside_0_to_1() -> None:
    result = CliRunner().invoke(cli, ["rehearse", "-n", "1", "--drop-out", "1.5"])
    assert result.exit_code == 2
    assert "--drop-out" in result.output


SEED, PEOPLE, RATE = 6, 7, 0.3


@pytest.mark.slow
def test_the_dashboard_and_analysis_handle_the_situations(tmp_path: Path) -> None:
    expected = plan(SEED, PEOPLE, RATE, RATE)
    assert any(s.stop_at == 0 for s in expected), "pick a seed with each situation"
    assert any(s.stop_at in (1, 2, 3) for s in expected)
    assert any(s.deviate_at is not None and s.stop_at is None for s in expected)
    settings = Settings(
        data_dir=tmp_path / "data", secret_key=secrets.token_urlsafe(32), _env_file=None
    )
    options = Options(PEOPLE, seed=SEED, script="silent", drop_out=RATE, deviate=RATE)
    with embedded_system(settings) as target:
        summary = rehearse(target, options)
    text = "\n".join(summary.lines())
    unstarted = sum(s.stop_at == 0 for s in expected)
    ended = sum(s.stop_at in (1, 2, 3) for s in expected)
    deviated = sum(s.deviate_at is not None for s in expected)
    assert f"{unstarted} never started, {ended} ended early, {deviated} deviated" in text

    engine = build_engine(settings.effective_database_url)
    try:
        with build_sessionmaker(engine)() as db:
            study = db.scalars(select(Study)).one()
            sessions = list(db.scalars(select(Session).order_by(Session.id)))
            states = [s.state for s in sessions]
            assert states == [
                "pending" if s.stop_at == 0 else "ended" if s.stop_at else "complete"
                for s in expected
            ]
            reasons = [s.end_reason for s in sessions if s.state == "ended"]
            assert reasons == [s.reason for s in expected if s.stop_at]
            confirmed = db.scalars(select(Event).where(Event.kind == "condition.switched"))
            assert len(list(confirmed)) == deviated

            summaries = session_summaries(db, study, study_from_config(study.config))
            kinds = Counter(f.kind for s in summaries for f in s.flags.flags)
            assert kinds["not_started"] == unstarted, kinds
            assert kinds["ended_early"] == ended, kinds
            assert kinds["deviation"] >= deviated, kinds

            planned = study_analysis(db, include_rehearsal=True, view="as_planned")
            as_run = study_analysis(db, include_rehearsal=True, view="as_run")
    finally:
        engine.dispose()
    assert planned.analysis is not None, planned.error
    assert as_run.analysis is not None, as_run.error
    codes = summary.codes
    complete = {c for c, s in zip(codes, expected, strict=True) if s.stop_at is None}
    deviating = {c for c, s in zip(codes, expected, strict=True) if s.deviate_at is not None}
    # Incomplete participants leave each measure's test (missing, never 0); as run also
    # leaves out whoever deviated from the plan, and says so.
    assert planned.analysis.measures["accepted"].friedman.n == len(complete)
    assert as_run.analysis.measures["accepted"].friedman.n == len(complete - deviating)
    incomplete = set(planned.analysis.measures["accepted"].excluded)
    assert incomplete <= set(codes) - complete
    left_out = {out.participant for out in as_run.analysis.left_out}
    assert deviating & complete <= left_out
    assert not set(as_run.analysis.participants) & deviating
