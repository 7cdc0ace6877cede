"""A helper process that dies with the process that started it, even on ``kill -9``.

The parent passes its pid in ``PARENT_ENV``; the child calls :func:`die_with_parent` first.
On Linux the kernel sends the child SIGTERM when the parent dies (``prctl(PR_SET_PDEATHSIG)``,
see prctl(2)); everywhere a daemon thread also watches for being re-parented, and a parent
already gone before either was set up is noticed at once.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time

PARENT_ENV = "CHAMELEONS_PARENT_PID"
PR_SET_PDEATHSIG = 1
WATCH_INTERVAL_S = 0.5


def child_env(env: dict[str, str] | None = None) -> dict[str, str]:
    """The environment for a child that should die with this process."""
    return {**(os.environ if env is None else env), PARENT_ENV: str(os.getpid())}


def _orphaned(parent: int) -> bool:
    return os.getppid() != parent


def _watch(parent: int) -> None:
    while not _orphaned(parent):
        time.sleep(WATCH_INTERVAL_S)
    os.kill(os.getpid(), signal.SIGTERM)


def die_with_parent() -> None:
    value = os.environ.get(PARENT_ENV, "")
    if not value.isdigit():
        return  # started by hand: nothing to follow
    parent = int(value)
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
        except (OSError, AttributeError):
            pass  # the watcher below still works
    if _orphaned(parent):
        raise SystemExit(0)
    threading.Thread(target=_watch, args=(parent,), daemon=True, name="lifeline").start()
