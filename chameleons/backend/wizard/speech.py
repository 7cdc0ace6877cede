"""Watching the worker's speech start and end of one play.

The subscription to the booth's events is opened before the command goes out, so a worker
that starts speaking at once is not missed. Events are ``event.<booth>`` messages of type
``speech_start``/``speech_end`` whose body carries ``prompt_id`` and ``worker_time``.

The virtual robot's page also says why a play never started (``autoplay_blocked``: the
browser wants one click before it plays sound). That reason does not travel through the
worker, so :class:`DisplayWatch` hears it on the server's display channel, where the page
reports it, and the play's ``prompt.speech_end`` carries it to the console.
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

DISPLAY_FAILURES = {"autoplay_blocked": "robot display needs a click to enable sound"}

# (started, worker_time) -> logged
OnSpeech = Callable[[bool, float | None], Awaitable[None]]
# reason -> logged
OnFailure = Callable[[str], Awaitable[None]]


class DisplayWatch:
    """Listens on the display channel (from its creation, before the command goes out) for
    the page's report that this play could not start; call :meth:`wait` once."""

    def __init__(self, channel: Any, booth: str, prompt_id: str) -> None:
        self.channel, self.booth, self.prompt_id = channel, booth, prompt_id
        self.failed: asyncio.Future[str] = asyncio.get_running_loop().create_future()
        channel.add_listener(self._hear)

    def _hear(self, booth: str, message: dict[str, Any]) -> None:
        reason = message.get("reason")
        if (booth == self.booth and message.get("type") == "speech"
                and message.get("event") == "end" and reason in DISPLAY_FAILURES
                and message.get("prompt_id") == self.prompt_id
                and not self.failed.done()):  # fmt: skip
            self.failed.set_result(str(reason))

    def close(self) -> None:
        with contextlib.suppress(ValueError):
            self.channel.remove_listener(self._hear)

    async def wait(self, on_failure: OnFailure, timeout: float = START_TIMEOUT_SECONDS) -> None:
        """Report a failure the page gives within ``timeout``, then stop listening."""
        try:
            reason = await asyncio.wait_for(self.failed, timeout)
            await on_failure(reason)
        except TimeoutError:
            return
        except Exception:
            log.exception("watching the display for %s failed", self.prompt_id)
        finally:
            self.close()


def open_display(state: Any, booth: str, prompt_id: str) -> DisplayWatch | None:
    """A watch on the booth's display page, or None when this server has no display channel
    (no page ever connected: only a physical robot speaks)."""
    channel = getattr(state, "display_channel", None)
    if channel is None or not callable(getattr(channel, "add_listener", None)):
        return None
    return DisplayWatch(channel, booth, prompt_id)


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
