"""The reliability suite (``-m reliability``; part of ``make test``): floods, races, faults.

Sockets here trip their guards after a few messages whatever the machine's speed: the
rate limit is set so low that no refill happens during a test (no timing thresholds).
"""

from __future__ import annotations

import pytest

from chameleons.settings import Settings

BURST = 10


@pytest.fixture
def settings(settings: Settings) -> Settings:
    return settings.model_copy(
        update={"ws_message_rate": 0.001, "ws_message_burst": BURST, "ws_queue_limit": 8}
    )


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if "tests/reliability/" in str(item.fspath).replace("\\", "/"):
            item.add_marker(pytest.mark.reliability)
