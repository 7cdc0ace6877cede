"""Play and stop prompts: log the click, send the command, log the answer, watch the speech.

Database work runs in the thread pool in short write transactions of its own, so the click
is committed (and on the console's timeline) before the worker is asked, and the ack is
logged as soon as it arrives. Speech start/end are awaited in a background task per play.
"""

from __future__ import annotations

import asyncio
import contextlib
import inspect
import logging
import random
from collections.abc import Callable
from typing import Any, TypeVar
from urllib.parse import quote

from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from chameleons.backend.events.unit_of_work import write_scope
from chameleons.backend.models.base import utcnow
from chameleons.backend.wizard import service, worker_link
from chameleons.backend.wizard.service import Cue, Outcome
from chameleons.worker.control import PLAY_PROMPT, STOP_PROMPT

log = logging.getLogger(__name__)
T = TypeVar("T")
SPEECH_START_TIMEOUT = 5.0
SPEECH_END_MARGIN = 10.0


def write(state: Any, work: Callable[..., T], *args: Any) -> T:
    """Run ``work(db, *args)`` in a write transaction of its own (committed on return)."""
    scope = contextlib.contextmanager(write_scope)(state.sessionmaker, state.live_hub)
    with scope as db:
        return work(db, *args)


def read(state: Any, work: Callable[..., T], *args: Any) -> T:
    db: Session = state.sessionmaker()
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
    bridge = worker_link.bridge_of(state)
    outcome = await worker_link.send_command(bridge, cue.booth, PLAY_PROMPT, body)
    acked_at = utcnow()
    event = await run_in_threadpool(write, state, service.record_outcome, cue, outcome, acked_at)
    if outcome.sent:
        _watch_speech(state, bridge, cue)
    return {
        **cue.summary(),
        "sent": outcome.sent,
        "reason": outcome.reason,
        "detail": outcome.detail,
        "click_to_ack_ms": event.payload.get("click_to_ack_ms"),
    }


async def stop(state: Any, session_id: int) -> dict[str, Any]:
    booth = await run_in_threadpool(read, state, service.booth_of, session_id)
    outcome = await worker_link.send_command(worker_link.bridge_of(state), booth, STOP_PROMPT, {})
    event = await run_in_threadpool(write, state, service.record_stop, session_id, outcome)
    return {"event_id": event.id, "sent": outcome.sent, "reason": outcome.reason,
            "detail": outcome.detail}  # fmt: skip


def audio_url(state: Any, cue: Cue) -> str:
    """The URL the worker fetches the audio from; empty for a prompt not yet recorded (the
    worker then only times the prompt by its estimated duration)."""
    if cue.audio is None:
        return ""
    builder = getattr(state, "prompt_audio_url", None)
    if callable(builder):
        return str(builder(cue.actor, cue.audio))
    base = str(state.settings.effective_public_url)
    return f"{base}/media/prompts/{quote(cue.actor)}/{quote(cue.audio)}"


def _watch_speech(state: Any, bridge: Any, cue: Cue) -> None:
    """Log the worker's speech start/end for this play, in the background."""
    waiter = getattr(bridge, "wait_for_speech", None)
    if not callable(waiter):
        return
    tasks = _tasks(state)
    task = asyncio.get_running_loop().create_task(_speech(state, waiter, cue))
    tasks.add(task)
    task.add_done_callback(tasks.discard)


def _tasks(state: Any) -> set[asyncio.Task[None]]:
    tasks: set[asyncio.Task[None]] | None = getattr(state, "wizard_speech_tasks", None)
    if tasks is None:
        tasks = state.wizard_speech_tasks = set()
    return tasks


async def _speech(state: Any, waiter: Callable[..., Any], cue: Cue) -> None:
    timeouts = {"start": SPEECH_START_TIMEOUT, "end": cue.duration + SPEECH_END_MARGIN}
    for phase in ("start", "end"):
        try:
            answer = waiter(cue.booth, cue.prompt.id, phase, timeout=timeouts[phase])
            worker_time = await answer if inspect.isawaitable(answer) else answer
        except TimeoutError:
            return
        except Exception:
            log.exception("waiting for speech %s of %s failed", phase, cue.prompt.id)
            return
        received = utcnow()
        moment = float(worker_time) if isinstance(worker_time, int | float) else None
        await run_in_threadpool(
            write, state, service.record_speech, cue, phase == "start", received, moment
        )


__all__ = ["Outcome", "audio_url", "play", "read", "stop", "write"]
