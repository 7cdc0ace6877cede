"""Rehearse -> export, end to end with a real worker and a simulated face: every
interaction with recordings has sync_lag_s, sync_r, mimicry_r and mimicry_lag_s (or says
why not), computed in the background while the rehearsal runs, and the copy interactions
measure the copy's 4 s delay to within 0.15 s."""

from __future__ import annotations

import csv
import secrets
from pathlib import Path

import pytest
from click.testing import CliRunner

from chameleons.cli.main import cli
from chameleons.rehearsal.embedded import embedded_system
from chameleons.rehearsal.runner import Options, rehearse
from chameleons.settings import Settings

# Shorter windows than the default 30 s keep the rehearsal to a few minutes: each
# interaction's discussion is held HOLD seconds, enough for a 10 s window and the 6 s lag,
# and for the within-interaction baseline's four shuffled segments of at least 6 s.
HOLD = 30.0
# One participant: the default study's plan gives each participant every condition once
# (still, natural, copy), so one session covers every behaviour in half the time of two.
PARTICIPANTS = 1


@pytest.mark.slow
def test_a_rehearsal_exports_synchrony_for_every_recorded_interaction(tmp_path: Path) -> None:
    settings = Settings(data_dir=tmp_path / "data", secret_key=secrets.token_urlsafe(32),
                        sync_window_s=10.0, sync_increment_s=5.0, sync_surrogates=20,
                        _env_file=None)  # fmt: skip
    with embedded_system(settings) as target:
        summary = rehearse(target, Options(PARTICIPANTS, seed=3, script="brief", hold=HOLD))
    assert len(summary.codes) == PARTICIPANTS
    out = tmp_path / "export"
    env = {"CHAMELEONS_DATABASE_URL": settings.effective_database_url}
    result = CliRunner().invoke(cli, ["export", "--include-rehearsal", "--out", str(out)],
                                env=env, catch_exceptions=False)  # fmt: skip
    assert result.exit_code == 0, result.output
    with (out / "interactions.csv").open(encoding="utf-8", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 3 * PARTICIPANTS
    assert sorted(r["behaviour"] for r in rows) == ["copy", "natural", "still"] * PARTICIPANTS
    copies = [r for r in rows if r["behaviour"] == "copy"]
    for row in rows:
        assert row["sync_missing"] not in ("no_recording", "not_computed"), row
        if row["sync_missing"]:
            assert row["sync_missing"] == "robot_still", row  # nothing else may be empty
            assert row["sync_note"], row  # and that comes with the reason in words
            continue
        for column in ("sync_lag_s", "sync_r", "mimicry_r", "mimicry_lag_s"):
            assert row[column] != "", (column, row)
    for row in copies:
        assert row["sync_missing"] == "", row
        assert float(row["sync_lag_s"]) == pytest.approx(4.0, abs=0.15), row
        assert row["sync_check"] == "ok", row["sync_check_reason"]
        assert row["sync_face_source"] == "livelink"
        assert float(row["sync_usable_share"]) > 0.8
