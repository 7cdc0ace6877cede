"""The independent check of the bench's HTTP timing (``bench.independent_check``): wrk's
output is read as wrk prints it, and a short A B A B run gives both generators' figures
against the same real server."""

from __future__ import annotations

import pytest

from bench.independent_check import TO_MS, WRK_PERCENTILE, WRK_RATE, compare

pytestmark = pytest.mark.slow

# What Debian's wrk 4.1.0 printed here for `wrk -t1 -c1 -d1s --latency` against a local
# `python3 -m http.server` (a fixed port in this text only: no server is started).
WRK_OUTPUT = """Running 1s test @ http://127.0.0.1:18777/
  1 threads and 1 connections
  Thread Stats   Avg      Stdev     Max   +/- Stdev
    Latency     0.92ms  810.76us   7.97ms   88.34%
    Req/Sec     1.09k   399.21     1.79k    80.00%
  Latency Distribution
     50%  576.00us
     75%    1.20ms
     90%    1.86ms
     99%    4.08ms
  1086 requests in 1.00s, 1.38MB read
Requests/sec:   1083.79
Transfer/sec:      1.38MB
"""


def test_wrk_output_is_read_in_milliseconds() -> None:
    found = {q: float(v) * TO_MS[unit] for q, v, unit in WRK_PERCENTILE.findall(WRK_OUTPUT)}
    assert found == pytest.approx({"50": 0.576, "99": 4.08})
    rate = WRK_RATE.search(WRK_OUTPUT)
    assert rate is not None
    assert float(rate.group(1)) == 1083.79


def test_both_generators_read_the_same_server_twice() -> None:
    runs = compare([1], 1.0)
    assert list(runs) == ["1"]
    assert list(runs["1"]) == ["wrk 1", "bench 1", "wrk 2", "bench 2"]
    for name, figures in runs["1"].items():
        assert 0 < figures["p50_ms"] <= figures["p99_ms"], name
        assert figures["per_second"] > 0, name
