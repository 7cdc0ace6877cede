"""Watching the worker's speech start and end of one play.

The subscription to the booth's events is opened before the command goes out, so a worker
that starts speaking at once is not missed. Events are ``event.<booth>`` messages of type
``speech_start``/``speech_end`` whose body carries ``prompt_id`` and ``worker_time``.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable
from typing import Any

log = logging.getLogger(__name__)
SPEECH_START = "speech_start"
SPEECH_END = "speech_end"
START_TIMEOUT_SECONDS = 5.0
END_MARGIN_SECONDS = 10.0

# (started, worker_time) -> logged
OnSpeech = Callable[[bool, float | None], Awaitable[None]]


def open_events(bridge: Any | None, booth: str) -> Any | None:
    """A subscription to the booth's events, or None when the bridge cannot give one."""
    subscribe = getattr(bridge, "subscribe", None)
    if not callable(subscribe):
        return None
    try:
        return subscribe(booth, ("event",))
    except Exception:  # no events: the play still works, only its speech times are missing
        log.exception("cannot subscribe to the events of %s", booth)
        return None


def close(subscription: Any | None) -> None:
    if subscription is not None:
        with contextlib.suppress(Exception):
            subscription.close()


async def _next(subscription: Any, kind: str, prompt_id: str) -> float | None:
    """The worker time of the next ``kind`` event of ``prompt_id``."""
    async for message in subscription:
        body = getattr(message, "body", {}) or {}
        if getattr(message, "type", None) == kind and body.get("prompt_id") == prompt_id:
            moment = body.get("worker_time")
            return float(moment) if isinstance(moment, int | float) else None
    raise TimeoutError("the event subscription closed")


async def watch(subscription: Any, prompt_id: str, duration: float, on_speech: OnSpeech) -> None:
    """Report speech start, then end, of ``prompt_id``; give up quietly on a timeout."""
    try:
        phases = ((True, SPEECH_START, START_TIMEOUT_SECONDS),
                  (False, SPEECH_END, duration + END_MARGIN_SECONDS))  # fmt: skip
        for started, kind, timeout in phases:
            worker_time = await asyncio.wait_for(_next(subscription, kind, prompt_id), timeout)
            await on_speech(started, worker_time)
    except TimeoutError:
        return
    except Exception:
        log.exception("watching the speech of %s failed", prompt_id)
    finally:
        close(subscription)
