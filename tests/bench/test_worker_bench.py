"""The worker benchmark's booth runs (real worker processes, each with a simulated phone
streaming Live Link over UDP): the per-second jitter comes from the workers' heartbeats,
also with the renderer in a process of its own."""

from __future__ import annotations

import pytest

from bench.worker_bench import booths

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("options", [(), ("--renderer-process",)])
def test_a_booth_reports_its_per_second_jitter(options: tuple[str, ...]) -> None:
    row = booths(1, 2.0, options)
    assert row["booths"] == 1
    assert row["worst_booth_median_p99_ms"] > 0  # a real loop never ticks exactly on time
    assert row["max_p99_ms"] >= row["worst_booth_median_p99_ms"]
    assert row["cpu_per_booth"] > 0
