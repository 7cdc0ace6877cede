"""Ctrl-C and SIGTERM for the commands that run until stopped (serve, demo, rehearse).

One handler owns SIGINT and SIGTERM from the start of the command to its end. It records
the first signal, asks whatever the command runs to stop (the registered stoppers: an
embedded web server), and the command then leaves with the conventional status,
128 + the signal (130 for Ctrl-C, 143 for SIGTERM), once everything it started has stopped.

Why one owner, and why the status comes from the record (issue 36):

- uvicorn installs its own handlers while it serves (``Server.capture_signals``), shuts
  down quietly on the signal and raises it again only afterwards, into whatever handler
  was there before: under ``asyncio.Runner`` that one cancels the main task, and
  ``uvicorn.run`` swallows the ``KeyboardInterrupt`` that follows, so ``chameleons serve``
  exited 0 after Ctrl-C (uvicorn issue #1579 "uvicorn eats SIGINTs"; #1600 added the
  re-raise). The servers here therefore never install handlers (:mod:`.web_server`);
  this handler stops them through ``should_exit``, as uvicorn's own handler does.
- Python delivers a signal as an exception in the main thread wherever it happens to be,
  and an exception raised while a finalizer or a weakref callback runs there is printed
  as "Exception ignored" and lost: the command then carries on as if nothing happened
  (a rehearsal went on to finish and exited 0). The record survives that: stoppers end
  the work, :meth:`Interrupts.check` raises again at the command's next step, and the
  exit status is taken from the record, not from whichever exception got through.

A second signal while the command stops is recorded too; it forces a server's shutdown
(uvicorn's "press Ctrl-C again") but raises nothing, so the clean-up that stops the
command's helpers is not itself cut short.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Any

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
# A stopper is told whether this is a repeated signal (then: stop at once, not gracefully).
Stopper = Callable[[bool], None]


class Interrupted(SystemExit):
    """Leaving a command because of a stop signal; the exit status is 128 + the signal.

    A ``SystemExit``: click lets it through as the exit status, ``except Exception`` blocks
    do not catch it, and asyncio and uvloop re-raise it out of their loops."""

    def __init__(self, signum: int) -> None:
        super().__init__(128 + signum)
        self.signum = signum


class Interrupts:
    """The stop signals one command received (see the module's docstring)."""

    def __init__(self) -> None:
        self.signum: int | None = None
        self.received = 0
        self._stoppers: list[Stopper] = []
        self._quiet = 0  # > 0 while a server in the main thread stops through its flags

    def handle(self, signum: int, _frame: FrameType | None) -> None:
        """The signal handler (main thread)."""
        self.received += 1
        again = self.signum is not None
        if not again:
            self.signum = signum
        for stop in list(self._stoppers):
            stop(again)
        if not again and not self._quiet:
            raise Interrupted(signum)

    def check(self) -> None:
        """Raise :class:`Interrupted` when a stop signal came (call between steps)."""
        if self.signum is not None:
            raise Interrupted(self.signum)

    @contextlib.contextmanager
    def stopping(self, stopper: Stopper, *, quiet: bool = False) -> Iterator[None]:
        """Call ``stopper`` on each stop signal while the block runs. ``quiet``: the block
        runs an event loop in this thread that stops by ``stopper`` alone; the handler then
        raises nothing into it, and :meth:`check` afterwards tells the signal."""
        self._stoppers.append(stopper)
        self._quiet += quiet
        try:
            yield
        finally:
            self._quiet -= quiet
            self._stoppers.remove(stopper)


def _install(handler: Callable[[int, FrameType | None], None]) -> dict[int, Any] | None:
    if threading.current_thread() is not threading.main_thread():
        return None  # signals reach the main thread only; a command run elsewhere (a test)
    return {signum: signal.signal(signum, handler) for signum in STOP_SIGNALS}


@contextlib.contextmanager
def interrupts() -> Iterator[Interrupts]:
    """Own SIGINT and SIGTERM while the block runs; leave with :class:`Interrupted` (status
    128 + signal) when one came, whatever else the block raised or returned."""
    received = Interrupts()
    previous = _install(received.handle)
    try:
        yield received
    finally:
        if previous is not None:
            for signum, handler in previous.items():
                signal.signal(signum, handler)
        if received.signum is not None:
            # The signal is why the block ended, whatever it raised on the way out (a
            # rehearsal whose server went away, click's Abort): the status says so.
            raise Interrupted(received.signum)
