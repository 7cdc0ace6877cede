"""``chameleons synchrony``: computes and stores every recorded interaction of a study (or
a session, or one interaction) with the parameters given, and refuses impossible ones."""

from __future__ import annotations

import secrets
from pathlib import Path

import pytest
from click.testing import CliRunner
from sqlalchemy import select

from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.migrate import upgrade
from chameleons.backend.models import InteractionSynchrony
from chameleons.cli.main import cli
from tests.backend.synchrony.recorded import recorded_study


@pytest.fixture
def database(tmp_path: Path) -> tuple[str, dict[str, str]]:
    url = f"sqlite:///{tmp_path / 'data' / 'chameleons.sqlite3'}"
    (tmp_path / "data").mkdir()
    upgrade(url)
    engine = build_engine(url)
    with session_scope(build_sessionmaker(engine)) as db:
        recorded_study(db, tmp_path / "data", participants=1)
    engine.dispose()
    env = {"CHAMELEONS_DATABASE_URL": url, "CHAMELEONS_DATA_DIR": str(tmp_path / "data"),
           "CHAMELEONS_SECRET_KEY": secrets.token_urlsafe(32)}  # fmt: skip
    return url, env


def stored(url: str) -> list[InteractionSynchrony]:
    engine = build_engine(url)
    try:
        with build_sessionmaker(engine)() as db:
            return list(db.scalars(select(InteractionSynchrony).order_by(
                InteractionSynchrony.interaction_id)))  # fmt: skip
    finally:
        engine.dispose()


def test_it_computes_a_study_with_the_parameters_given(
    database: tuple[str, dict[str, str]],
) -> None:
    url, env = database
    ran = CliRunner().invoke(cli, ["synchrony", "--window", "20", "--increment", "10",
                                   "--surrogates", "10"], env=env)  # fmt: skip
    assert ran.exit_code == 0, ran.output
    assert "[1/3] interaction 1:" in ran.output
    assert "copy check ok: The robot followed at 4.00 s." in ran.output
    assert "no values: The robot's head and face did not move" in ran.output
    assert "computed 3 interaction(s); 0 copy check(s) failed" in ran.output
    rows = stored(url)
    assert len(rows) == 3
    assert {r.params["window_s"] for r in rows} == {20.0}
    assert {r.params["surrogates"] for r in rows} == {10}
    again = CliRunner().invoke(cli, ["synchrony", "--interaction", str(rows[0].interaction_id)],
                               env=env)  # fmt: skip
    assert again.exit_code == 0, again.output
    assert "computed 1 interaction(s)" in again.output
    assert len(stored(url)) == 3  # replaced, not added
    assert stored(url)[0].params["window_s"] == 30.0  # the settings' default this time


def test_impossible_parameters_are_refused_in_a_sentence(
    database: tuple[str, dict[str, str]],
) -> None:
    _, env = database
    ran = CliRunner().invoke(cli, ["synchrony", "--window", "7.31"], env=env)
    assert ran.exit_code != 0
    assert "window_s = 7.31 s is not a whole number of samples at 25 Hz" in ran.output
    missing = CliRunner().invoke(cli, ["synchrony", "--session", "999"], env=env)
    assert missing.exit_code != 0
    assert "no recorded interactions to compute" in missing.output
