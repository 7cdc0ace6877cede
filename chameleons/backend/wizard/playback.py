"""Play and stop prompts: log the click, send the command, log the answer, watch the speech.

Database work runs in the thread pool in short write transactions of its own, so the click
is committed (and on the console's timeline) before the worker is asked, and the ack is
logged as soon as it arrives. Speech start/end are awaited in a background task per play.
"""

from __future__ import annotations

import asyncio
import contextlib
import random
from collections.abc import Callable, Coroutine
from types import SimpleNamespace
from typing import Any, TypeVar, cast

from fastapi import FastAPI
from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from chameleons.backend.display.channel import DISPLAY_CLOSED
from chameleons.backend.display.media import media_path
from chameleons.backend.display.tokens import signing_key
from chameleons.backend.events.unit_of_work import write_scope
from chameleons.backend.models.base import utcnow
from chameleons.backend.wizard import service, speech, typed_speech, worker_link
from chameleons.backend.wizard.service import Cue, Outcome
from chameleons.worker.control import PLAY_PROMPT, STOP_PROMPT
from chameleons.worker.drivers import plays_wav, speaks_text

T = TypeVar("T")


def write(state: Any, work: Callable[..., T], *args: Any) -> T:
    """Run ``work(db, *args)`` in a write transaction of its own (committed on return)."""
    scope = contextlib.contextmanager(write_scope)(state.sessionmaker, state.live_hub)
    with scope as db:
        return work(db, *args)


def read(state: Any, work: Callable[..., T], *args: Any) -> T:
    db: Session = state.read_sessionmaker()
    try:
        return work(db, *args)
    finally:
        db.close()


async def play(
    state: Any, session_id: int, group: str, rng: random.Random | None = None
) -> dict[str, Any]:
    cue = await run_in_threadpool(write, state, service.start_play, state, session_id, group, rng)
    body = {"prompt_id": cue.prompt.id, "audio_url": audio_url(state, cue)}
    if cue.lipsync is not None:
        body["lipsync_path"] = cue.lipsync
    return await _deliver(state, cue, body)


async def say(state: Any, session_id: int, text: str) -> dict[str, Any]:
    """The wizard's typed sentence in the actor's voice (``typed_speech``): synthesised
    here for the virtual robot, the text itself for a robot with its own TTS (a Furhat)."""
    booth = await run_in_threadpool(read, state, service.booth_of, session_id)
    robot_tts = speaks_text(_driver(state, booth) or "")
    cue, spoken = await run_in_threadpool(
        write, state, typed_speech.start_typed, state, session_id, text, robot_tts
    )
    body: dict[str, Any] = {"prompt_id": cue.prompt.id}
    if isinstance(spoken, typed_speech.TypedAudio):
        body["audio_url"] = typed_speech.media_url(state, spoken.digest)
    else:
        body.update(audio_url="", text=spoken.text, voice=spoken.voice)
    return await _deliver(state, cue, body)


async def _deliver(state: Any, cue: Cue, body: dict[str, Any]) -> dict[str, Any]:
    """Send a logged play to the booth's worker; log its outcome and watch its speech."""
    bridge = worker_link.bridge_of(state)
    play_id = play_id_of(cue)
    events = speech.open_events(bridge, cue.booth)
    display = speech.open_display(state, cue.booth, cue.prompt.id, play_id)
    outcome = await worker_link.send_command(bridge, cue.booth, PLAY_PROMPT,
                                             {**body, "play_id": play_id})  # fmt: skip
    acked_at = utcnow()
    event = await run_in_threadpool(write, state, service.record_outcome, cue, outcome, acked_at)
    if outcome.sent and events is not None:
        on_speech = _logger(state, cue, play_id)
        _spawn(state, speech.watch(events, cue.prompt.id, cue.duration, on_speech,
                                   _not_voiced_logger(state, cue, display), play_id))  # fmt: skip
        if display is not None:
            _spawn(state, display.wait(_failure_logger(state, cue)))
    else:
        speech.close(events)
        if display is not None:
            display.close()
    return {
        **cue.summary(),
        "sent": outcome.sent,
        "reason": outcome.reason,
        "detail": outcome.detail,
        "click_to_ack_ms": event.payload.get("click_to_ack_ms"),
    }


def play_id_of(cue: Cue) -> str:
    """This play's own id on the wire: its ``prompt.played`` event's id (the worker's
    speech events carry it back; the same prompt may be played twice)."""
    return f"play-{cue.event_id}"


async def stop(state: Any, session_id: int) -> dict[str, Any]:
    booth = await run_in_threadpool(read, state, service.booth_of, session_id)
    outcome = await worker_link.send_command(worker_link.bridge_of(state), booth, STOP_PROMPT, {})
    event = await run_in_threadpool(write, state, service.record_stop, session_id, outcome)
    return {"event_id": event.id, "sent": outcome.sent, "reason": outcome.reason,
            "detail": outcome.detail}  # fmt: skip


def audio_url(state: Any, cue: Cue) -> str:
    """The keyed URL the robot fetches the audio from (WAV for a Furhat, which cannot play
    MP3); empty for a prompt not yet recorded (the worker then shows only lip-sync/text)."""
    if cue.audio is None:
        return ""
    key = signing_key(cast(FastAPI, SimpleNamespace(state=state)))
    path = media_path(key, cue.actor, cue.audio, wav=plays_wav(_driver(state, cue.booth) or ""),
                      language=cue.language_folder)  # fmt: skip
    return f"{state.settings.effective_public_url}{path}"


def _driver(state: Any, booth: str) -> str | None:
    workers = getattr(worker_link.bridge_of(state), "workers", None)
    if not callable(workers):
        return None
    info = workers().get(booth)
    hello = getattr(info, "hello", None) or {}
    return hello.get("driver") if isinstance(hello, dict) else None


def _logger(state: Any, cue: Cue, play_id: str) -> speech.OnSpeech:
    async def log_speech(started: bool, worker_time: float | None, outcome: str | None) -> None:
        # The robot display went while it played (closed, reloaded): the participant did
        # not hear it to its end, so the end says why (the console shows it not voiced).
        cut = not started and _display_cut_short(state, cue, play_id)
        await run_in_threadpool(
            write, state, service.record_speech, cue, started, utcnow(), worker_time, outcome,
            DISPLAY_CLOSED if cut else None,
        )

    return log_speech


def _display_cut_short(state: Any, cue: Cue, play_id: str) -> bool:
    channel = getattr(state, "display_channel", None)
    cut_short = getattr(channel, "cut_short", None)
    return bool(callable(cut_short) and cut_short(cue.booth, cue.prompt.id, play_id))


def _not_voiced_logger(
    state: Any, cue: Cue, display: speech.DisplayWatch | None
) -> speech.OnNotVoiced:
    async def log_not_voiced(detail: str) -> None:
        if display is not None and display.said_why():
            return  # the display said why already (e.g. it needs a click for sound)
        why = _virtual_robot_absence(state, cue.booth) or detail
        if display is not None and display.audio_error:
            why = _audio_error(cue)
        await run_in_threadpool(write, state, service.record_not_voiced, cue, why, utcnow())

    return log_not_voiced


def _audio_error(cue: Cue) -> str:
    """Why the display could not voice a play it was sent: the file it could not load."""
    if cue.audio is None:
        return "the prompt has no audio recording"
    where = "/".join(part for part in (cue.language_folder, cue.actor, cue.audio) if part)
    return f"the robot display could not load or play the prompt's audio ({where})"


def _virtual_robot_absence(state: Any, booth: str) -> str | None:
    """Why the virtual robot could not voice it: no display page of the booth open."""
    if _driver(state, booth) != "virtual":
        return None
    channel = getattr(state, "display_channel", None)
    connected = getattr(channel, "connected", None)
    if callable(connected) and connected(booth) > 0:
        return None
    return f"no robot display open for {booth}"


def _failure_logger(state: Any, cue: Cue) -> speech.OnFailure:
    async def log_failure(reason: str) -> None:
        detail = speech.DISPLAY_FAILURES.get(reason, reason)
        await run_in_threadpool(
            write, state, service.record_display_failure, cue, reason, detail, utcnow()
        )

    return log_failure


def _spawn(state: Any, work: Coroutine[Any, Any, None]) -> None:
    """Run ``work`` in the background, keeping a reference so it is not collected."""
    tasks: set[asyncio.Task[None]] | None = getattr(state, "wizard_speech_tasks", None)
    if tasks is None:
        tasks = state.wizard_speech_tasks = set()
    task = asyncio.get_running_loop().create_task(work)
    tasks.add(task)
    task.add_done_callback(tasks.discard)


__all__ = ["Outcome", "audio_url", "play", "read", "stop", "write"]
