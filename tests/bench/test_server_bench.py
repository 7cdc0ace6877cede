"""The server benchmark runs (two phones, no think time): every phone submission of a whole
session reaches its console socket, against the real server and the baseline alike."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]


def test_the_server_benchmark_smoke_run(tmp_path: Path) -> None:
    out = tmp_path / "figures.json"
    command = [sys.executable, "-m", "bench.server_bench", "--phones", "2", "--think-max", "0",
               "--only", "sqlite", "--json", str(out)]  # fmt: skip
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=600,
                          check=False)  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    report = json.loads(out.read_text())
    real, baseline = report["SQLite"], report["SQLite baseline"]
    # A session of the default study: 3 rankings and every questionnaire page, per phone.
    assert real["think"]["submissions"] >= 2 * 3 * 2
    assert real["burst"]["submissions"] == 2
    for scenario in (real["think"], real["burst"], baseline["think"], baseline["burst"]):
        assert scenario["errors"] == {}
        assert scenario["update_p99_ms"] > 0
        assert scenario["server_cpu_ms_per_submission"] >= 0  # clock ticks: a burst of 2 may be 0
    assert real["think"]["server_cpu_ms_per_submission"] > 0  # two whole sessions cost CPU
    assert "submit -> console update" in done.stdout
    assert "server CPU / submission" in done.stdout
