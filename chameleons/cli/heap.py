"""The server process's garbage collector, set once the application is built.

A full (oldest-generation) collection walks every tracked object, and the application's
own, made at start-up and alive until exit (modules, SQLAlchemy's mappers, pydantic's
validators, the study specs: about 200,000 objects), are most of them. Each took about
180 ms with the whole process stopped, five times in a 45 s run of the server bench: the
slowest updates a console waited for were those stalls (bench/server_bench.py, 50 phones,
human-paced: submit -> console p99 100-210 ms; docs/performance.md). Collected once and
then frozen (``gc.freeze``: the collector no longer looks at them), the start-up objects
cost nothing; what a request leaves in reference cycles is still collected by the young
generations, whose threshold is raised so they run less often on many short-lived objects.
"""

from __future__ import annotations

import gc

# Allocations (less deallocations) between young collections; CPython's default is 700.
YOUNG_THRESHOLD = 10_000


def settle_startup_heap() -> None:
    """Collect what start-up left unreachable, then freeze the rest (call it once, after the
    application is built and before it serves: anything frozen is never collected)."""
    gc.collect()
    gc.freeze()
    _young, middle, old = gc.get_threshold()
    gc.set_threshold(YOUNG_THRESHOLD, middle, old)
