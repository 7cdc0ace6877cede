"""The display benchmark runs (a few seconds per face): the 2D face and the 3D head in
Chromium with software WebGL, fed a copying robot's stream; every figure is there for both,
with the 3D head's ratios to the 2D baseline."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.browser]  # Chromium, in the bench's own process
ROOT = Path(__file__).resolve().parents[2]


def test_the_display_benchmark_smoke_run(tmp_path: Path) -> None:
    out = tmp_path / "display.json"
    command = [sys.executable, "-m", "bench.display_bench", "--quick", "--json", str(out)]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=600,
                          check=False)  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    report = json.loads(out.read_text())
    assert report["viewport"] == "1280x800"
    for kind in ("2d", "3d"):
        figures = report[kind]
        assert figures["renderer"] == kind
        assert figures["seconds"] >= 2
        assert figures["fps"] > 0
        assert figures["frames_in_per_s"] > 0
        assert figures["frame_ms_p50"] > 0
        assert figures["arrival_to_pixels_p50_ms"] > 0
        assert figures["cpu_cores"] > 0
    assert report["3d_vs_2d"]["frame_ms_p50_x_2d"] > 0
    assert "3d / 2d" in done.stdout
