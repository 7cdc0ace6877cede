"""The delay-sweep template rehearses end to end with a real worker: six scripted
participants, the export says per interaction what the robot copied and how late, and the
yoked control replays the clip for the first participants and then another participant's
recorded copy stream."""

from __future__ import annotations

import csv
import json
import secrets
from pathlib import Path

import pytest
from click.testing import CliRunner

from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.migrate import upgrade
from chameleons.backend.studies import service as studies
from chameleons.cli.main import cli
from chameleons.experiment.study import load_study
from chameleons.experiment.templates import study_templates
from chameleons.rehearsal.embedded import embedded_system
from chameleons.rehearsal.runner import Options, rehearse
from chameleons.settings import Settings


def read(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


@pytest.mark.slow
def test_the_delay_sweep_rehearses_and_exports_what_the_robot_copied(tmp_path: Path) -> None:
    settings = Settings(
        data_dir=tmp_path / "data", secret_key=secrets.token_urlsafe(32), _env_file=None
    )
    url = settings.effective_database_url
    upgrade(url)
    engine = build_engine(url)
    with session_scope(build_sessionmaker(engine)) as db:
        study = studies.create_study(db, load_study(study_templates()["delay_sweep"]), 7)
        studies.generate_plan(db, study, 6)
        study_id = study.id
    engine.dispose()
    with embedded_system(settings, study_id, simulate_face=True) as target:
        summary = rehearse(target, Options(6, seed=3, pattern="effect", script="silent"))
    assert len(summary.codes) == 6
    out = tmp_path / "export"
    runner = CliRunner(env={"CHAMELEONS_DATABASE_URL": url})
    exported = runner.invoke(cli, ["export", "--include-rehearsal", "--out", str(out)])
    assert exported.exit_code == 0, exported.output
    rows = read(out / "interactions.csv")
    assert len(rows) == 6 * 3
    # The scripted participants are fast: a robot set-up can still be on its way when an
    # interaction (or the session) has ended, and is then not made; the rest say it all.
    expected = {"copy_fast": "copies everything, 0.7 s late, mirror image",
                "copy_slow": "copies everything, 4 s late, mirror image"}  # fmt: skip
    set_up = [r for r in rows if r["behaviour_words"]]
    assert len(set_up) >= 12
    for row in set_up:
        if row["condition"] in expected:
            assert row["behaviour_words"] == expected[row["condition"]]
            assert json.loads(row["behaviour_params"])["delay"] == (
                0.7 if row["condition"] == "copy_fast" else 4.0
            )
        else:
            assert row["behaviour_words"].startswith("replays clip demo-natural (yoked: no ")
    yoked = [r for r in rows if r["condition"] == "yoked"]
    assert all(r["behaviour"] == "yoked_copy" for r in yoked)
    # Rehearsal interactions are shorter than the 30 s a yoked recording needs: every yoked
    # interaction replayed the study's clip, as the rule for the first participants says.
    assert {r["natural_source"] for r in yoked if r["behaviour_words"]} == {"clip"}
