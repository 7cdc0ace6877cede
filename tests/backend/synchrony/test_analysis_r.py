"""analysis.R's synchrony section, run by R (lme4), against the Python analysis of the same
exported files: the mimicry model's condition effect and the covariate slopes agree."""

from __future__ import annotations

import csv
import math
import random
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.cli.analyze_command import read_csv_rows, read_scores_csv
from chameleons.experiment.stats.synchrony.outcomes import analyze_synchrony, coefficient
from tests.support.factories import populate

RSCRIPT = shutil.which("Rscript")
MIMICRY = {"natural": 0.05, "copy": 0.3}


def fill_synchrony(path: Path, seed: int) -> None:
    """Give the exported interactions synchrony values with a known structure."""
    rng = random.Random(seed)
    with path.open(encoding="utf-8", newline="") as handle:
        reader = csv.DictReader(handle)
        fields, rows = reader.fieldnames or [], list(reader)
    for row in rows:
        condition = row["planned_condition"]
        if condition == "still":
            row.update(sync_missing="robot_still", sync_note="The robot did not move.")
            continue
        z = MIMICRY[condition] + rng.gauss(0, 0.15)
        row.update(sync_lag_s="4.0" if condition == "copy" else "2.5",
                   sync_r="0.95" if condition == "copy" else "0.2",
                   sync_check="ok" if condition == "copy" else "",
                   mimicry_r=f"{math.tanh(z):.6f}", mimicry_lag_s="1.2")  # fmt: skip
    with path.open("w", encoding="utf-8", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)


@pytest.mark.skipif(RSCRIPT is None, reason="R is not installed here (.ci/run installs it)")
def test_r_and_python_agree_on_the_mimicry_models(db_session: DbSession, tmp_path: Path) -> None:
    assert RSCRIPT is not None
    probe = subprocess.run([RSCRIPT, "-e", "library(lme4); library(ordinal)"],
                           capture_output=True, text=True, check=False)  # fmt: skip
    if probe.returncode != 0:
        pytest.skip("R is installed without lme4 or ordinal")
    populate(db_session, 12, seed=5)
    db_session.flush()
    export_to_directory(db_session, ExportRequest(), tmp_path)
    fill_synchrony(tmp_path / "interactions.csv", seed=5)
    ran = subprocess.run([RSCRIPT, "analysis.R"], cwd=tmp_path, capture_output=True,
                         text=True, check=False, timeout=600)  # fmt: skip
    assert ran.returncode == 0, ran.stderr[-3000:]
    assert re.search(r"^synchrony copy\s+12 interactions: sync_r mean 0\.9500 \(n = 12\)",
                     ran.stdout, re.M), ran.stdout[-3000:]  # fmt: skip
    assert "copy checks ok 12, failed 0" in ran.stdout
    ours = analyze_synchrony(
        read_csv_rows(tmp_path / "interactions.csv"), read_scores_csv(tmp_path / "scores.csv"),
        conditions=("natural", "copy", "still"), reference="still",
        measures=("credibility", "likeability", "trust"),
    )  # fmt: skip
    assert ours is not None
    assert ours.mimicry_model is not None
    copy = coefficient(ours.mimicry_model, "condition", "natural")  # baseline: copy (no still)
    assert copy is not None
    r_copy = re.search(r"^mimicry_z coefficient conditionnatural = (-?[\d.]+) \(SE ([\d.]+)\)",
                       ran.stdout, re.M)  # fmt: skip
    assert r_copy is not None, ran.stdout[-3000:]
    assert copy.estimate == pytest.approx(float(r_copy.group(1)), abs=1e-4)
    assert copy.se == pytest.approx(float(r_copy.group(2)), rel=1e-3)
    for measure in ("credibility", "likeability", "trust"):
        slope = coefficient(ours.covariate_models[measure], "mimicry_z")
        assert slope is not None
        r_slope = re.search(rf"^{measure} ~ mimicry_z: (-?[\d.]+) \(SE ([\d.]+)\), n = 24",
                            ran.stdout, re.M)  # fmt: skip
        assert r_slope is not None, ran.stdout[-3000:]
        assert slope.estimate == pytest.approx(float(r_slope.group(1)), abs=2e-4)
