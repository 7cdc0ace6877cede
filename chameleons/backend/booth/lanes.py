"""The booth flow's lanes: jobs queued by key (a session, a session's robot, a booth) run on
the event loop one after another per key, lanes side by side. A failed job is logged and
the lane goes on; a lane's task ends when it is empty."""

from __future__ import annotations

import asyncio
import logging
from collections import deque
from collections.abc import Awaitable, Callable

# The flow's logger: a failed job is reported as the booth flow's, as before the split.
log = logging.getLogger("chameleons.backend.booth.flows")
Job = Callable[[], Awaitable[None]]


class Lanes:
    def __init__(self) -> None:
        self._lanes: dict[str, deque[Job]] = {}
        self._tasks: dict[str, asyncio.Task[None]] = {}
        self.stopped = False

    def enqueue(self, key: str, job: Job) -> None:
        """Queue ``job`` behind the others of ``key`` (call from the running loop); once
        closed, nothing is queued."""
        if self.stopped:
            return
        lane = self._lanes.get(key)
        if lane is None:
            lane = self._lanes[key] = deque()
            self._tasks[key] = asyncio.create_task(self._drain(key, lane))
        lane.append(job)

    async def settled(self) -> None:
        """Wait until every queued job has run."""
        while self._tasks:
            await asyncio.gather(*list(self._tasks.values()), return_exceptions=True)

    async def close(self) -> None:
        """Queue nothing more and cancel what is still queued or running."""
        self.stopped = True
        tasks = list(self._tasks.values())
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    async def _drain(self, key: str, lane: deque[Job]) -> None:
        try:
            while lane:
                job = lane.popleft()
                try:
                    await job()
                except Exception:  # one failed reaction must not stop the others
                    log.exception("booth flow job on %s failed", key)
        finally:
            # No await between the empty check and here: nothing can be queued meanwhile.
            if self._lanes.get(key) is lane:
                del self._lanes[key]
                del self._tasks[key]
