"""The synchrony benchmark runs in its quick size and reports its figures beside the
baseline of the same run (the copy it times is measured at its delay)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench import synchrony_bench


def test_quick_run_writes_the_figures(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "synchrony.json"
    assert synchrony_bench.main(["--quick", "--json", str(out)]) == 0
    figures = json.loads(out.read_text(encoding="utf-8"))
    assert figures["measured_lag_s"] == pytest.approx(4.0, abs=0.05)
    assert figures["channels"] == 55
    assert figures["surrogate_kind"] == "between"
    assert figures["per_interaction_s"] > figures["real_pair_s"] > 0
    assert figures["per_interaction_ratio"] == pytest.approx(
        figures["per_interaction_s"] / figures["bare_numpy_s"]
    )
    assert "x the baseline" in capsys.readouterr().out
