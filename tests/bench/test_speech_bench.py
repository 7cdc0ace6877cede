"""The speech benchmark runs (one counted play per robot): a real server and worker, the
display page in Chromium and the Furhat peer; each play's speech start is seen at the robot
and then on the console, and every figure comes with the bare WebSocket baseline."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.browser]  # Chromium, in the bench's own process
ROOT = Path(__file__).resolve().parents[2]


def test_the_speech_benchmark_smoke_run(tmp_path: Path) -> None:
    out = tmp_path / "speech.json"
    command = [sys.executable, "-m", "bench.speech_bench", "--plays", "1", "--json", str(out)]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=900,
                          check=False)  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    report = json.loads(out.read_text())
    baseline = report["baseline_ws_round_trip"]
    assert 0 < baseline["p50_ms"] <= baseline["p99_ms"]
    for robot in ("virtual", "furhat"):
        figures = report[robot]
        assert figures["plays"] == 1
        assert figures["errors"] == {}
        for key in ("ack", "robot", "console"):
            assert figures[f"{key}_p50_ms"] > 0
            assert figures[f"{key}_p99_x_baseline"] > 0
        # The console hears of the start from the robot, through the worker: later.
        slack = figures.get("clock_uncertainty_max_ms", 0.0)
        assert figures["console_p50_ms"] > figures["robot_p50_ms"] - slack
    assert "click -> speech start at the robot" in done.stdout
