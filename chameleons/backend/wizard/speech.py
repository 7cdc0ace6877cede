"""Watching the worker's speech start and end of one play.

The subscription to the booth's events is opened before the command goes out, so a worker
that starts speaking at once is not missed. Events are ``event.<booth>`` messages of type
``speech_start``/``speech_end`` whose body carries ``prompt_id``, ``play_id`` and
``worker_time``. Each play has its own ``play_id`` (sent with ``play_prompt``, carried by
the worker's speech events of that play): an event is credited to a play only when its
``play_id`` is the play's, so when the same prompt is played again while it speaks, the
first play's interrupted end is never taken for the second's. (An event without a
``play_id``, from a worker that sends none, is placed by its ``prompt_id``.)

A play that no robot voices is not voiced: no speech start within
:data:`START_TIMEOUT_SECONDS`, an end before any start (the robot skipped it, or was not
connected), or an end with outcome ``failed`` (a Furhat's ``response.speak.end`` with
``failed: true``: it could not play the audio, also after its speech start).
:func:`watch` reports it through ``on_not_voiced`` with the reason; the play
is then logged ``prompt.not_voiced``, shown NOT VOICED on the console and counted in the
dashboard's data-quality flags.

The virtual robot's page also says why a play never started (``autoplay_blocked``: the
browser wants one click before it plays sound; ``error``: it could not load or play the
audio, e.g. a file the server does not have). That reason does not travel through the
worker, so :class:`DisplayWatch` hears it on the server's display channel, where the page
reports it (before the report is forwarded to the worker, whose answer would otherwise
overtake it): a blocked autoplay ends the play's ``prompt.speech_end`` with the reason, an
audio the page could not load is the play's NOT VOICED reason.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable
from typing import Any

from chameleons.backend.display.relay import RELAY_PLAY_MARK

log = logging.getLogger(__name__)
SPEECH_START = "speech_start"
SPEECH_END = "speech_end"
START_TIMEOUT_SECONDS = 5.0
END_MARGIN_SECONDS = 10.0

DISPLAY_FAILURES = {"autoplay_blocked": "robot display needs a click to enable sound"}
# The page's end of a play it could not load or play (before any start of it).
AUDIO_ERROR = "error"

# (started, worker_time, outcome) -> logged; outcome "played", "interrupted", "stopped"...
OnSpeech = Callable[[bool, float | None, str | None], Awaitable[None]]
# why it was not voiced -> logged
OnNotVoiced = Callable[[str], Awaitable[None]]
NOT_STARTED = "the robot never started speaking it"
FAILED = "failed"  # the outcome of a speech end the robot could not play
# reason -> logged
OnFailure = Callable[[str], Awaitable[None]]


class DisplayWatch:
    """Listens on the display channel (from its creation, before the command goes out) for
    the page's report that this play could not start; call :meth:`wait` once."""

    def __init__(
        self, channel: Any, booth: str, prompt_id: str, play_id: str | None = None
    ) -> None:
        self.channel, self.booth, self.prompt_id = channel, booth, prompt_id
        self.play_id = play_id
        self.failed: asyncio.Future[str] = asyncio.get_running_loop().create_future()
        self.started = False
        self.audio_error = False  # the page could not load or play the audio
        channel.add_listener(self._hear, first=True)

    def _hear(self, booth: str, message: dict[str, Any]) -> None:
        if (booth != self.booth or message.get("type") != "speech"
                or message.get("prompt_id") != self.prompt_id
                or not _same_play(message.get("play_id"), self.play_id)):  # fmt: skip
            return
        event, reason = message.get("event"), message.get("reason")
        if event == "start":
            self.started = True
        elif event == "end" and reason == AUDIO_ERROR and not self.started:
            self.audio_error = True
        elif event == "end" and reason in DISPLAY_FAILURES and not self.failed.done():
            self.failed.set_result(str(reason))

    def said_why(self) -> bool:
        """The page reported why this play could not start (waiting may have cancelled the
        future: that is not a report)."""
        return self.failed.done() and not self.failed.cancelled()

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


def open_display(
    state: Any, booth: str, prompt_id: str, play_id: str | None = None
) -> DisplayWatch | None:
    """A watch on the booth's display page, or None when this server has no display channel
    (no page ever connected: only a physical robot speaks)."""
    channel = getattr(state, "display_channel", None)
    if channel is None or not callable(getattr(channel, "add_listener", None)):
        return None
    return DisplayWatch(channel, booth, prompt_id, play_id)


def _same_play(reported: Any, play_id: str | None) -> bool:
    """An event of this play: its ``play_id`` is the play's (one without is placed by its
    prompt id alone: a worker or page that sends none)."""
    if play_id is None or not reported or RELAY_PLAY_MARK in str(reported):
        return True  # no play id from the worker: the page knows the relay's own id only
    return bool(reported == play_id)


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


async def _next(
    subscription: Any, prompt_id: str, play_id: str | None = None
) -> tuple[str, dict[str, Any]]:
    """The next speech event (type, body) of this play of ``prompt_id``."""
    async for message in subscription:
        body = getattr(message, "body", {}) or {}
        kind = getattr(message, "type", None)
        if (kind in (SPEECH_START, SPEECH_END) and body.get("prompt_id") == prompt_id
                and _same_play(body.get("play_id"), play_id)):  # fmt: skip
            return str(kind), dict(body)
    raise TimeoutError("the event subscription closed")


async def next_speech(
    subscription: Any, prompt_id: str, play_id: str | None = None
) -> tuple[str, dict[str, Any]]:
    """The next speech event of this play (also for the booth check's test prompt)."""
    return await _next(subscription, prompt_id, play_id)


def _time(body: dict[str, Any]) -> float | None:
    moment = body.get("worker_time")
    return float(moment) if isinstance(moment, int | float) else None


def _why_silent(body: dict[str, Any]) -> str:
    """Why a play ended before it started (or failed), from the worker's speech end."""
    error, outcome = body.get("error"), body.get("outcome")
    if error:
        return str(error)
    if outcome == "skipped":
        return "skipped: another prompt was played before it started"
    if outcome == FAILED:
        return "the robot could not play it"
    return "the robot ended it before it started"


def failed(body: dict[str, Any]) -> bool:
    """The speech end says the robot could not play it (it was not heard)."""
    return body.get("outcome") == FAILED


async def watch(
    subscription: Any, prompt_id: str, duration: float, on_speech: OnSpeech,
    on_not_voiced: OnNotVoiced | None = None, play_id: str | None = None,
) -> None:  # fmt: skip
    """Report speech start, then end, of this play (``play_id``) of ``prompt_id``; a play
    that never starts (no start in time, or an end first) goes to ``on_not_voiced``; a late
    end is given up quietly."""
    try:
        try:
            kind, body = await asyncio.wait_for(_next(subscription, prompt_id, play_id),
                                                START_TIMEOUT_SECONDS)  # fmt: skip
        except TimeoutError:
            if on_not_voiced is not None:
                await on_not_voiced(NOT_STARTED)
            return
        if kind == SPEECH_END:
            if on_not_voiced is not None:
                await on_not_voiced(_why_silent(body))
            return
        await on_speech(True, _time(body), None)
        while kind != SPEECH_END:
            kind, body = await asyncio.wait_for(_next(subscription, prompt_id, play_id),
                                                duration + END_MARGIN_SECONDS)  # fmt: skip
        if failed(body) and on_not_voiced is not None:  # it started, and was never heard
            await on_not_voiced(_why_silent(body))
            return
        outcome = body.get("outcome")
        await on_speech(False, _time(body), str(outcome) if outcome else None)
    except TimeoutError:
        return
    except Exception:
        log.exception("watching the speech of %s failed", prompt_id)
    finally:
        close(subscription)
