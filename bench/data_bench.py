"""Data benchmark: planning, export and analysis at study scale, each figure against a
baseline measured in the same run.

``python -m bench.data_bench [--participants 1000] [--plan-rows 1200] [--repeat 3] [--quick]``

- **planning**: ``plan(study, 1200)`` for the default study (balanced blocks, every
  constraint checked) against drawing the same number of rows at random with no balancing
  (``random.sample`` of the conditions' orders).
- **export**: ``export_to_directory`` (CSV, every table and the codebook) of N completed
  participants (the tests' data factory on a SQLite file built by the migrations) against
  a bare pandas dump of the same database tables (``read_sql_table`` + ``to_csv``).
- **analysis**: the analysis page for 100 and N participants (``bench.analysis_bench``:
  its first render and its effect sizes and models, each set against the paper's
  analysis alone, with their peak memory).

Times are medians over ``--repeat`` runs; peak memory is Python's allocations (tracemalloc,
which also sees NumPy's and pandas' buffers) in a separate run, since tracing slows the
code it measures.
"""

from __future__ import annotations

import argparse
import json
import random
import statistics
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from itertools import permutations
from pathlib import Path
from typing import Any

import pandas as pd
from sqlalchemy import inspect

from bench import analysis_bench
from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.migrate import upgrade
from chameleons.experiment.design import plan
from chameleons.experiment.study import default_study_path, load_study
from tests.support.factories import populate


def measure(action: Callable[[], object], repeat: int) -> dict[str, float]:
    """Median milliseconds over ``repeat`` runs, then the peak of one traced run in MiB."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    tracemalloc.start()
    try:
        action()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return {"ms": round(statistics.median(times) * 1000, 3), "peak_mib": round(peak / 2**20, 2)}


def ratio(ours: dict[str, float], baseline: dict[str, float]) -> float:
    return round(ours["ms"] / max(baseline["ms"], 1e-6), 1)


def planning(rows: int, repeat: int) -> dict[str, Any]:
    study = load_study(default_study_path())
    orders = list(permutations(study.condition_ids))
    rng = random.Random(1)
    planned = measure(lambda: plan(study, rows, seed=1), repeat)
    drawn = measure(lambda: [rng.choice(orders) for _ in range(rows)], repeat)
    return {"rows": rows, "plan": planned, "baseline_random_orders": drawn,
            "x_baseline": ratio(planned, drawn)}  # fmt: skip


def export(participants: int, repeat: int, folder: Path) -> dict[str, Any]:
    url = f"sqlite:///{folder / 'bench.sqlite3'}"
    upgrade(url)
    engine = build_engine(url)
    factory = build_sessionmaker(engine)
    started = time.perf_counter()
    with session_scope(factory) as db:
        populate(db, participants, seed=1)
    filled = time.perf_counter() - started
    runs = iter(range(10**6))

    def ours() -> None:
        with factory() as db:
            export_to_directory(db, ExportRequest(formats=("csv",)), folder / f"ours{next(runs)}")

    def bare() -> None:
        out = folder / f"bare{next(runs)}"
        out.mkdir()
        with engine.connect() as connection:
            for table in inspect(engine).get_table_names():
                pd.read_sql_table(table, connection).to_csv(out / f"{table}.csv", index=False)

    csv, dump = measure(ours, repeat), measure(bare, repeat)
    engine.dispose()
    return {"participants": participants, "fill_s": round(filled, 1), "export_csv": csv,
            "baseline_pandas_dump": dump, "x_baseline": ratio(csv, dump)}  # fmt: skip


def parser() -> argparse.ArgumentParser:
    found = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    found.add_argument("--participants", type=int, default=1000)
    found.add_argument("--plan-rows", type=int, default=1200)
    found.add_argument("--repeat", type=int, default=3)
    found.add_argument("--quick", action="store_true", help="20 participants, 120 rows, 1 run")
    found.add_argument("--json", type=Path, default=None, help="also write the figures here")
    return found


def main(argv: list[str] | None = None) -> None:
    args = parser().parse_args(argv)
    if args.quick:
        args.participants, args.plan_rows, args.repeat = 20, 120, 1
    figures: dict[str, Any] = {"planning": planning(args.plan_rows, args.repeat)}
    with tempfile.TemporaryDirectory() as folder:
        figures["export"] = export(args.participants, args.repeat, Path(folder))
    sizes = sorted({min(100, args.participants), args.participants})
    figures["analysis"] = [analysis_bench.run(n, args.repeat) for n in sizes]
    text = json.dumps(figures, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n")


if __name__ == "__main__":
    main()
