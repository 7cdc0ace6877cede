"""The server process collects what start-up left unreachable and freezes the rest before it
serves (chameleons.cli.heap); run in a child process, so this one's collector is untouched."""

from __future__ import annotations

import json
import subprocess
import sys

from chameleons.cli.heap import YOUNG_THRESHOLD

CHILD = """
import gc, json, weakref

from chameleons.backend.app import create_app
from chameleons.cli.heap import settle_startup_heap
from chameleons.settings import Settings


class Node:
    pass


gc.disable()  # the cycle below must still exist when settle_startup_heap runs
cycle = Node()
cycle.self = cycle
garbage = weakref.ref(cycle)
del cycle
app = create_app(Settings(database_url="sqlite:///:memory:", demo_mode=True))
kept = weakref.ref(app)
gc.enable()
settle_startup_heap()
print(json.dumps({
    "garbage_freed": garbage() is None,
    "app_kept": kept() is not None,
    "frozen": gc.get_freeze_count(),
    "app_frozen": not any(o is app for o in gc.get_objects()),
    "threshold": gc.get_threshold(),
}))
"""


def test_start_up_garbage_is_collected_and_the_rest_frozen_before_serving() -> None:
    done = subprocess.run(
        [sys.executable, "-c", CHILD], capture_output=True, text=True, timeout=300, check=False
    )
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found["garbage_freed"]  # collected first: a cycle frozen would never be freed
    assert found["app_kept"]
    assert found["app_frozen"]  # the application's objects are out of the collector's walks
    assert found["frozen"] > 10_000
    assert found["threshold"][0] == YOUNG_THRESHOLD
