"""`chameleons analyze` from the database equals `chameleons analyze --scores` on the export."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from click.testing import CliRunner

from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.cli.analyze_command import analyze_command
from chameleons.cli.export_command import export
from tests.support.factories import populate


def test_database_mode_matches_the_exported_scores(sqlite_template: Path, tmp_path: Path) -> None:
    database = tmp_path / "study.sqlite3"
    shutil.copyfile(sqlite_template, database)
    engine = build_engine(f"sqlite:///{database}")
    with session_scope(build_sessionmaker(engine)) as db:
        populate(db, 12, rehearsals=1, seed=3)
    engine.dispose()
    env = {k: v for k, v in os.environ.items() if not k.startswith("CHAMELEONS_")}
    env["CHAMELEONS_DATABASE_URL"] = f"sqlite:///{database}"
    runner = CliRunner(env=env)
    assert runner.invoke(export, ["--out", str(tmp_path / "out")]).exit_code == 0
    for output in ("json", "latex", "text"):
        from_db = runner.invoke(analyze_command, ["--format", output])
        from_file = runner.invoke(
            analyze_command, ["--scores", str(tmp_path / "out" / "scores.csv"), "--format", output]
        )
        assert from_db.exit_code == 0, from_db.output
        assert from_db.output == from_file.output
    # Both read the item answers (the file mode from questionnaire.csv beside scores.csv).
    text = runner.invoke(analyze_command, []).output
    assert "Internal consistency (Cronbach's alpha): all ratings, with an interval" in text
    assert "  Trust: alpha = " in text
    # 36 ratings from 12 people: the pooled interval resamples people; per condition Feldt.
    assert "(percentile bootstrap over participants; n = 36 complete ratings from 12 " in text
    assert "    Copy: alpha = " in text
    assert "(Feldt; n = 12 complete ratings from 12 participants, 6 items)" in text
    # Both read the per-suggestion rows (the file mode from suggestions.csv beside scores.csv).
    models = json.loads(runner.invoke(analyze_command, ["--format", "json"]).output)["models"]
    assert models["acceptance"]["n_observations"] == 108
    assert "C(kind)" not in models["acceptance"]["formula"]  # the total effect
    assert "C(kind)" in models["acceptance_by_kind"]["formula"]
    # The suggestion mix per condition, with or without the models, from either source.
    for args in ([], ["--no-models"], ["--scores", str(tmp_path / "out" / "scores.csv"),
                                       "--no-models"]):  # fmt: skip
        text = runner.invoke(analyze_command, args).output
        assert "Suggestion mix per condition" in text
        assert "  Copy                   36 suggestions: " in text
    with_rehearsal = runner.invoke(analyze_command, ["--format", "json", "--include-rehearsal"])
    assert '"n": 13' in with_rehearsal.output
    missing = runner.invoke(analyze_command, ["--study", "42"])
    assert missing.exit_code == 1
    assert "there is no study with id 42" in missing.output
