"""The console's DOM spot check (``bench.console_dom_bench``) in Chromium: each ranking is
timed until the console's page shows it and until the console's message reaches a socket
of the bench's own, from the same moment."""

from __future__ import annotations

import pytest

from bench.console_dom_bench import run

pytestmark = pytest.mark.browser


def test_each_ranking_is_timed_on_the_page_and_on_the_socket() -> None:
    found = run(2)
    assert found["submissions"] == 2
    assert found["errors"] == {}
    for figure in ("state", "dom"):
        # After the submission started (a ranking shown before it would have raised) and
        # within the bench's own bound of a minute.
        assert 0 < found[f"{figure}_p50_ms"] <= found[f"{figure}_p99_ms"] < 60_000, figure
