"""Runs a local worker as a child process and restarts it when it dies.

The child is ``chameleons worker`` (run as ``python -m chameleons.cli.worker_command``, which
skips the server's imports) connected to the bridge's endpoints. When it exits without
being asked to, it is started again after a backoff that doubles up to ``max_backoff``
(and resets once a run lasted ``stable_after`` seconds). The bridge sees the new worker
instance in its hello, announces ``worker_restarted`` and re-sends the booth's behaviour,
face and recording, so the supervisor itself needs to know nothing about that state.

The worker runs in its own session: a Ctrl-C in the server's terminal reaches only the server,
which then stops the worker itself (no "worker exited, restarting" during shutdown). On Linux
the worker also gets SIGTERM when the server dies, even by SIGKILL (``PR_SET_PDEATHSIG``), so
no orphaned worker keeps the robot and the capture ports. The signal is tied to the thread
that started the worker: the thread running the event loop, which outlives the supervisor.
"""

from __future__ import annotations

import asyncio
import contextlib
import ctypes
import logging
import os
import signal
import sys
import time
from collections.abc import Callable, Mapping, Sequence

from chameleons.backend.bridge.bridge import Bridge

log = logging.getLogger(__name__)
WORKER_MODULE = "chameleons.cli.worker_command"
PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def die_with_parent_hook() -> Callable[[], None] | None:
    """A ``preexec_fn`` that makes the child get SIGTERM when its parent dies (Linux only).

    libc is looked up here, in the parent: between fork and exec the child should only make
    the system call, not load libraries."""
    if not sys.platform.startswith("linux"):
        return None
    prctl = ctypes.CDLL(None, use_errno=True).prctl
    parent = os.getpid()

    def hook() -> None:
        prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
        if os.getppid() != parent:  # the parent died before the request took effect
            os.kill(os.getpid(), signal.SIGTERM)

    return hook


class WorkerSupervisor:
    def __init__(
        self, bridge: Bridge, booth: str, args: Sequence[str] = (), *,
        env: Mapping[str, str] | None = None, backoff: float = 0.5, max_backoff: float = 10.0,
        stable_after: float = 30.0, stop_timeout: float = 5.0,
    ) -> None:  # fmt: skip
        self.bridge, self.booth, self.args = bridge, booth, list(args)
        self.env = dict(env) if env is not None else None
        self.backoff, self.max_backoff, self.stable_after = backoff, max_backoff, stable_after
        self.stop_timeout = stop_timeout
        self.process: asyncio.subprocess.Process | None = None
        self.starts = 0
        self.exit_codes: list[int] = []
        self._stopping = asyncio.Event()
        self._task: asyncio.Task[None] | None = None

    @property
    def command(self) -> list[str]:
        return [sys.executable, "-m", WORKER_MODULE, "--booth", self.booth,
                "--control", self.bridge.command_endpoint,
                "--telemetry", self.bridge.telemetry_endpoint, *self.args]  # fmt: skip

    @property
    def running(self) -> bool:
        return self.process is not None and self.process.returncode is None

    async def start(self) -> None:
        """Start the worker (call after ``bridge.start()``: the endpoints must be bound)."""
        self._stopping.clear()
        self._task = asyncio.create_task(self._supervise())

    async def stop(self) -> None:
        self._stopping.set()
        await self._terminate()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None

    async def _supervise(self) -> None:
        delay = self.backoff
        while not self._stopping.is_set():
            started = time.monotonic()
            hook = die_with_parent_hook()
            self.process = await asyncio.create_subprocess_exec(
                *self.command, env=self.env, start_new_session=True, preexec_fn=hook
            )
            self.starts += 1
            code = await self.process.wait()
            self.exit_codes.append(code)
            if self._stopping.is_set():
                return
            log.warning("worker of %s exited with %s; restarting in %.1f s", self.booth, code,
                        delay)  # fmt: skip
            if time.monotonic() - started > self.stable_after:
                delay = self.backoff
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._stopping.wait(), delay)
            delay = min(delay * 2, self.max_backoff)

    async def _terminate(self) -> None:
        process = self.process
        if process is None or process.returncode is not None:
            return
        process.terminate()  # SIGTERM: the worker closes its recordings and the robot link
        try:
            await asyncio.wait_for(process.wait(), self.stop_timeout)
        except TimeoutError:
            process.kill()
            await process.wait()
