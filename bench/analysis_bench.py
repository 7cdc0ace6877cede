"""Analysis page benchmark: how long the PI waits, each figure against a baseline measured
in the same run.

``python -m bench.analysis_bench [--participants N] [--repeat R] [--json FILE]``

A SQLite database built by the migrations gets N completed sessions (the tests' data
factory), then, through the real app (ASGI, logged in as a PI):

- **first render**: ``GET /pi/analysis`` with every cache cleared (the HTML the browser
  shows at once: Table I, the Friedman tests, placeholders for the rest); the goal is
  under 1 s for 100 participants; and warm (the data unchanged since the last visit:
  served from the page's cache after reading the data version);
- **effect sizes and models**: ``GET /pi/analysis/extended`` cold (cache cleared: the
  bootstrap intervals and the statsmodels fits) and warm (cached for unchanged data);
- **baseline**: the same data through the paper's analysis alone (the service call the
  page made before effect sizes and models existed), and ``GET /healthz`` (the HTTP
  stack with a database round trip).

Figures are medians over R repetitions (after one warm-up request, which also pays the
one-off imports), with their ratio to the baseline; then the **peak memory** of one more
first render and one more cold extended load, each in a run of its own under tracemalloc
(Python's allocations, NumPy's and pandas' buffers included; tracing slows the code, so
these runs are not timed), against the paper's analysis alone traced the same way.
"""

from __future__ import annotations

import argparse
import json
import secrets
import statistics
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient

from chameleons.backend.analysis.cache import analyses
from chameleons.backend.analysis.service import study_analysis
from chameleons.backend.app import create_app
from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.migrate import upgrade
from chameleons.settings import Settings
from tests.backend.test_auth import add_user, login
from tests.support.factories import populate


def _median_seconds(action: Callable[[], object], repeat: int, before: Callable[[], None]) -> float:
    times = []
    for _ in range(repeat):
        before()
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def _peak_mib(action: Callable[[], object], before: Callable[[], None]) -> float:
    """The peak of Python's allocations during one run of ``action``, in MiB."""
    before()
    tracemalloc.start()
    try:
        action()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return round(peak / 2**20, 2)


def run(participants: int, repeat: int) -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as folder:
        url = f"sqlite:///{Path(folder) / 'bench.sqlite3'}"
        upgrade(url)
        engine = build_engine(url)
        with session_scope(build_sessionmaker(engine)) as db:
            populate(db, participants, seed=1)
        add_user(engine, "pi-bench", "bench password", "pi")
        settings = Settings(
            database_url=url,
            data_dir=Path(folder) / "data",
            secret_key=secrets.token_urlsafe(32),
            bridge_enabled=False,
            _env_file=None,
        )
        with TestClient(create_app(settings)) as client:
            login(client, "pi-bench", "bench password")

            def get(path: str) -> Callable[[], object]:
                def request() -> object:
                    response = client.get(path)
                    if response.status_code != 200:
                        raise RuntimeError(f"{path}: HTTP {response.status_code}")
                    return response

                return request

            def classic() -> object:
                with build_sessionmaker(engine)() as db:
                    return study_analysis(db, extended=False)

            for path in ("/pi/analysis", "/pi/analysis/extended", "/healthz"):
                get(path)()  # warm-up: imports, templates, first connections
            nothing = lambda: None  # noqa: E731
            figures = {
                "baseline_paper_analysis_s": _median_seconds(classic, repeat, analyses.clear),
                "baseline_healthz_s": _median_seconds(get("/healthz"), repeat, nothing),
                "first_render_s": _median_seconds(get("/pi/analysis"), repeat, analyses.clear),
                "first_render_warm_s": _median_seconds(get("/pi/analysis"), repeat, nothing),
                "extended_cold_s": _median_seconds(
                    get("/pi/analysis/extended"), repeat, analyses.clear
                ),
                "extended_warm_s": _median_seconds(get("/pi/analysis/extended"), repeat, nothing),
                "json_cold_s": _median_seconds(get("/api/pi/analysis"), repeat, analyses.clear),
            }
            memory = {
                "baseline_paper_analysis_peak_mib": _peak_mib(classic, analyses.clear),
                "first_render_peak_mib": _peak_mib(get("/pi/analysis"), analyses.clear),
                "extended_cold_peak_mib": _peak_mib(get("/pi/analysis/extended"), analyses.clear),
            }
        engine.dispose()
    base = figures["baseline_paper_analysis_s"]
    return {
        "participants": participants,
        "repeat": repeat,
        **{k: round(v, 4) for k, v in figures.items()},
        **memory,
        "first_render_vs_paper_analysis": round(figures["first_render_s"] / base, 2),
        "extended_cold_vs_paper_analysis": round(figures["extended_cold_s"] / base, 2),
        "first_render_under_1s": figures["first_render_s"] < 1.0,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--participants", type=int, default=100)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--json", type=Path, default=None, help="also write the figures here")
    args = parser.parse_args()
    result = run(args.participants, args.repeat)
    text = json.dumps(result, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")


if __name__ == "__main__":
    main()
