"""The booth check's test prompt: the robot says one recorded prompt and must report its
speech start and end (a Furhat through its own speech events, the virtual robot through
its display page), as in a session, but logged with the check and not as a played prompt.
An end that says the robot could not play it (a Furhat's ``failed: true``, also after its
start) fails the step with the reason: the URL the robot was given, and the likely cause
when it names a loopback address (``CHAMELEONS_PUBLIC_URL`` not set).

The prompt is the first prompt with audio of the first actor in the catalogue
(``CHAMELEONS_BOOTH_CHECK_ACTOR`` picks another actor); its id on the wire is prefixed with
``booth-check:`` so nothing confuses it with a session's play.
"""

from __future__ import annotations

import asyncio
import time
import uuid
from types import SimpleNamespace
from typing import Any, cast

from fastapi import FastAPI

from chameleons.backend.display.media import media_path
from chameleons.backend.display.tokens import signing_key
from chameleons.backend.wizard import speech, worker_link
from chameleons.backend.wizard.catalogues import MissingCatalogueError, catalogue_for
from chameleons.prompts import Catalogue, Prompt
from chameleons.prompts.loader import actor_directories
from chameleons.prompts.locations import prompts_root
from chameleons.worker.control import PLAY_PROMPT
from chameleons.worker.drivers import plays_wav

PREFIX = "booth-check:"


def test_prompt(state: Any) -> tuple[Catalogue, Prompt] | None:
    """The actor's catalogue and the prompt the check plays (None: no recorded prompt)."""
    settings = state.settings
    wanted = getattr(settings, "booth_check_actor", None)
    actors = [wanted] if wanted else [d.name for d in actor_directories(prompts_root(settings))]
    for actor in sorted(actors):
        try:
            catalogue = catalogue_for(state, actor)
        except MissingCatalogueError:
            continue
        prompt = next((p for p in catalogue.prompts if p.audio is not None), None)
        if prompt is not None:
            return catalogue, prompt
    return None


def _audio_url(state: Any, actor: str, prompt: Prompt, booth: str) -> str:
    workers = getattr(worker_link.bridge_of(state), "workers", None)
    info = workers().get(booth) if callable(workers) else None
    hello = getattr(info, "hello", None) or {}
    furhat = isinstance(hello, dict) and plays_wav(str(hello.get("driver")))  # Furhat: WAV
    key = signing_key(cast(FastAPI, SimpleNamespace(state=state)))
    path = media_path(key, actor, str(prompt.audio), wav=furhat)
    return f"{state.settings.effective_public_url}{path}"


async def say_test_prompt(state: Any, booth: str) -> dict[str, Any]:
    """Play the test prompt on ``booth`` and wait for its speech start and end:
    ``{"prompt_id", "start_ms", "ended", "problem"}``."""
    chosen = test_prompt(state)
    if chosen is None:
        return {"prompt_id": None, "start_ms": None, "ended": False,
                "problem": "no recorded prompt in the catalogue to test with"}  # fmt: skip
    catalogue, prompt = chosen
    prompt_id = f"{PREFIX}{prompt.id}"
    play_id = f"booth-check-{uuid.uuid4().hex[:12]}"
    result: dict[str, Any] = {"prompt_id": prompt_id, "start_ms": None, "ended": False,
                              "problem": None}  # fmt: skip
    bridge = worker_link.bridge_of(state)
    events = speech.open_events(bridge, booth)
    url = _audio_url(state, catalogue.actor, prompt, booth)
    body = {"prompt_id": prompt_id, "play_id": play_id, "audio_url": url}
    sent_at = time.monotonic()
    try:
        outcome = await worker_link.send_command(bridge, booth, PLAY_PROMPT, body)
        if not outcome.sent or events is None:
            result["problem"] = outcome.detail or "no events from the worker"
            return result
        await _follow(events, prompt_id, play_id, catalogue.duration(prompt), sent_at, result)
        if result["problem"] is not None and url not in result["problem"]:
            result["problem"] += f" (the robot was given {url})"  # the robot's own problem
    finally:
        speech.close(events)
    return result


async def _follow(
    events: Any, prompt_id: str, play_id: str, duration: float, sent_at: float,
    result: dict[str, Any],
) -> None:  # fmt: skip
    try:
        kind, body = await asyncio.wait_for(speech.next_speech(events, prompt_id, play_id),
                                            speech.START_TIMEOUT_SECONDS)  # fmt: skip
    except TimeoutError:
        return
    if kind == speech.SPEECH_END:
        result["problem"] = _failure(body) if speech.failed(body) else (
            "the robot ended the prompt before it started"
            + (f": {body['error']}" if body.get("error") else ""))  # fmt: skip
        return
    result["start_ms"] = round((time.monotonic() - sent_at) * 1000.0, 1)
    try:
        while kind != speech.SPEECH_END:
            kind, body = await asyncio.wait_for(speech.next_speech(events, prompt_id, play_id),
                                                duration + speech.END_MARGIN_SECONDS)  # fmt: skip
    except TimeoutError:
        return
    if speech.failed(body):  # it started, and the robot could not play it
        result["problem"] = _failure(body)
        return
    result["ended"] = True


def _failure(body: dict[str, Any]) -> str:
    return str(body.get("error") or "the robot could not play the prompt")
