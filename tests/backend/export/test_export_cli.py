"""`chameleons export` against a real database file (in process: the subprocess start-up
of the CLI itself is covered by tests/backend/test_cli.py)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from click.testing import CliRunner

from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.cli.export_command import export
from chameleons.cli.main import cli
from tests.support.factories import populate


def _env(database: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("CHAMELEONS_")}
    env["CHAMELEONS_DATABASE_URL"] = f"sqlite:///{database}"
    env["CHAMELEONS_DATA_DIR"] = str(database.parent / "data")
    return env


def test_export_command_writes_the_bundle(sqlite_template: Path, tmp_path: Path) -> None:
    database = tmp_path / "study.sqlite3"
    shutil.copyfile(sqlite_template, database)
    engine = build_engine(f"sqlite:///{database}")
    with session_scope(build_sessionmaker(engine)) as db:
        populate(db, 4, rehearsals=1)
    engine.dispose()
    out = tmp_path / "out"
    result = CliRunner(env=_env(database)).invoke(
        cli, ["export", "--out", str(out), "--format", "json"]
    )
    assert result.exit_code == 0, result.output
    assert "participants 4" in result.output
    assert (out / "scores.csv").exists()
    assert (out / "scores.json").exists()
    assert not (out / "scores.parquet").exists()
    metadata = json.loads((out / "metadata.json").read_text())
    assert metadata["rows"]["interactions"] == 12
    rehearsed = CliRunner(env=_env(database)).invoke(
        export, ["--out", str(out), "--include-rehearsal"]
    )
    assert "participants 5" in rehearsed.output


def test_export_command_reports_a_missing_study(sqlite_template: Path, tmp_path: Path) -> None:
    database = tmp_path / "empty.sqlite3"
    shutil.copyfile(sqlite_template, database)
    runner = CliRunner(env=_env(database))
    result = runner.invoke(export, ["--out", str(tmp_path / "o"), "--study", "7"])
    assert result.exit_code == 1
    assert "there is no study with id 7" in result.output
    bad = runner.invoke(export, ["--out", str(tmp_path / "o"), "--format", "docx"])
    assert bad.exit_code == 2
    assert "docx" in bad.output
