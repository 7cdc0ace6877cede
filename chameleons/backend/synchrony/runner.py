"""Synchrony computed in the background: one worker thread of its own, never a request's
thread nor the worker's realtime loop (issue 32).

The booth flow submits an interaction when its recording has stopped and its files are
indexed; the thread reads the files, computes (:func:`service.compute`) and commits in its
own database session. One at a time, in submission order: a study's computations never
compete with each other for the CPU. A failure is logged and leaves the interaction
without a result (``chameleons synchrony`` computes it again). On shutdown the queue is
given ``drain_s`` seconds; what is left is logged by id.
"""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from functools import partial
from pathlib import Path

from sqlalchemy.orm import Session as DbSession

from chameleons.backend.synchrony import service
from chameleons.experiment.stats.synchrony import SyncParams

log = logging.getLogger(__name__)


class SynchronyRunner:
    def __init__(self, sessionmaker: Callable[[], DbSession], data_dir: Path,
                 params: SyncParams) -> None:  # fmt: skip
        self.sessionmaker, self.data_dir, self.params = sessionmaker, data_dir, params
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="synchrony")
        self._pending: dict[int, Future[None]] = {}
        self._lock = threading.Lock()
        self.computed = 0
        self.failed = 0

    def submit(self, interaction_id: int) -> Future[None]:
        """Queue the interaction (once: a second submission while it waits is the first)."""
        with self._lock:
            waiting = self._pending.get(interaction_id)
            if waiting is not None and not waiting.running() and not waiting.done():
                return waiting
            future = self._executor.submit(self._run, interaction_id)
            self._pending[interaction_id] = future
            future.add_done_callback(partial(self._forget, interaction_id))
            return future

    def _forget(self, interaction_id: int, future: Future[None]) -> None:
        with self._lock:
            if self._pending.get(interaction_id) is future:
                del self._pending[interaction_id]

    def _run(self, interaction_id: int) -> None:
        db = self.sessionmaker()
        try:
            service.compute(db, interaction_id, self.data_dir, self.params)
            db.commit()
            self.computed += 1
        except Exception:  # one interaction's failure must not stop the others
            db.rollback()
            self.failed += 1
            log.exception("synchrony of interaction %s failed", interaction_id)
        finally:
            db.close()

    async def settled(self) -> None:
        """Wait until everything submitted so far has run (tests, shutdown)."""
        while True:
            with self._lock:
                futures = list(self._pending.values())
            if not futures:
                return
            await asyncio.gather(*(asyncio.wrap_future(f) for f in futures),
                                 return_exceptions=True)  # fmt: skip

    async def stop(self, drain_s: float) -> None:
        try:
            await asyncio.wait_for(self.settled(), drain_s)
        except TimeoutError:
            with self._lock:
                left = sorted(self._pending)
            log.warning("synchrony not computed for interactions %s (server stopping): run "
                        "`chameleons synchrony` for them", left)  # fmt: skip
        self._executor.shutdown(wait=False, cancel_futures=True)
