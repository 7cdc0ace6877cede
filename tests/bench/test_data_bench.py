"""The data benchmark's parts run at a small size: planning and the export really produce
their output, and every figure comes with its baseline."""

from __future__ import annotations

from pathlib import Path

import pytest

from bench import analysis_bench
from bench.data_bench import export, planning

pytestmark = pytest.mark.slow


def test_planning_and_export_figures_with_baselines(tmp_path: Path) -> None:
    planned = planning(24, 1)
    assert planned["rows"] == 24
    assert planned["plan"]["ms"] > 0
    assert planned["baseline_random_orders"]["ms"] > 0
    assert planned["x_baseline"] > 0
    exported = export(4, 1, tmp_path)
    assert exported["export_csv"]["ms"] > 0
    assert exported["export_csv"]["peak_mib"] > 0
    assert exported["x_baseline"] > 0
    ours = sorted(tmp_path.glob("ours*"))
    assert len(ours) == 2  # one timed run, one traced run
    participants = (ours[0] / "participants.csv").read_text().splitlines()
    assert len(participants) == 1 + 4  # header and the four participants
    assert sorted(p.name for p in tmp_path.glob("bare*/participant.csv"))


def test_the_analysis_page_figures_come_with_their_peak_memory() -> None:
    figures = analysis_bench.run(4, 1)
    assert figures["participants"] == 4
    for name in ("baseline_paper_analysis", "first_render", "extended_cold"):
        assert figures[f"{name}_peak_mib"] > 0
    # The page renders from the paper's analysis of the same rows, and then some.
    assert figures["first_render_peak_mib"] > 0.5 * figures["baseline_paper_analysis_peak_mib"]
    assert figures["first_render_vs_paper_analysis"] > 0
