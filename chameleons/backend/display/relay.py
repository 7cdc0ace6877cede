"""Glue between the worker's ``virtual`` driver and the display pages.

``display_message`` turns one ``display.<booth>`` envelope of
:mod:`chameleons.worker.drivers.virtual` into the page protocol
(:mod:`chameleons.backend.display.protocol`); the bridge calls ``relay_envelope`` for every
such envelope it receives. ``forward_speech_events`` registers a channel listener that
sends the page's speech start/end back to the worker as ``speech_event`` commands.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Awaitable, Callable
from typing import Any

from chameleons.backend.display.channel import DisplayChannel
from chameleons.backend.display.protocol import (
    FACE_IDS,
    RENDERERS,
    Message,
    face_message,
    head_message,
    play_audio_message,
    set_face_message,
    stop_audio_message,
)
from chameleons.worker.control import SPEECH_EVENT
from chameleons.worker.envelope import Message as Envelope
from chameleons.worker.frames import N_BLENDSHAPES

DISPLAY_TOPIC_PREFIX = "display."
# A play id the relay makes itself (``prompt#seq``) for a worker that sent none: it names the
# play on the page only and is not sent back to the worker.
RELAY_PLAY_MARK = "#"
LipsyncResolver = Callable[[str], str | None]
SendCommand = Callable[[str, str, dict[str, Any]], Awaitable[object] | object]


class RelayError(ValueError):
    """An envelope the page protocol has no message for; ``reason`` is a counter key."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def booth_of(envelope: Envelope) -> str:
    if not envelope.topic.startswith(DISPLAY_TOPIC_PREFIX):
        raise RelayError("not_display_topic")
    return envelope.topic[len(DISPLAY_TOPIC_PREFIX) :]


def display_message(
    envelope: Envelope, lipsync_for: LipsyncResolver | None = None, served_from: str | None = None
) -> Message:
    """The page message for one virtual-driver envelope; raises :class:`RelayError`.
    ``lipsync_for(audio_url)`` may name the curves the page should play with the audio
    (e.g. ``functools.partial(media.lipsync_url_for, settings)``). URLs under
    ``served_from`` (this server's public URL) reach the page as paths: the page loads them
    from the address it was opened at. A booth screen on another computer opens the server
    by its LAN name, where ``http://127.0.0.1:8000`` (the public URL when none is set)
    would be the screen itself and every prompt would fail to play."""
    convert = _CONVERTERS.get(envelope.type)
    if convert is None:
        raise RelayError("unknown_type")
    try:
        message = convert(envelope)
    except RelayError:
        raise
    except (KeyError, TypeError, ValueError) as exc:
        raise RelayError(f"bad_{envelope.type}") from exc
    if message["type"] == "play_audio" and message["lipsync_url"] is None and lipsync_for:
        message["lipsync_url"] = lipsync_for(message["url"])
    if message["type"] == "play_audio" and served_from:
        for key in ("url", "lipsync_url"):
            message[key] = _as_path(message[key], served_from)
    return message


def _as_path(url: str | None, served_from: str) -> str | None:
    prefix = served_from.rstrip("/") + "/"
    return url[len(prefix) - 1 :] if url and url.startswith(prefix) else url


def _face(envelope: Envelope) -> Message:
    values = envelope.array().tolist()
    if len(values) < N_BLENDSHAPES:
        raise RelayError("short_face")
    # 52 blendshapes; a full 61-value face vector also carries head and eyes.
    head = values[N_BLENDSHAPES : N_BLENDSHAPES + 3] if len(values) >= 55 else None
    eyes = values[N_BLENDSHAPES + 3 : N_BLENDSHAPES + 9] if len(values) >= 61 else None
    return face_message(values[:N_BLENDSHAPES], head, eyes, seq=envelope.seq, sent=envelope.time)


def _head(envelope: Envelope) -> Message:
    pose = [float(envelope.body[k]) for k in ("yaw", "pitch", "roll")]
    if not all(math.isfinite(v) for v in pose):
        raise RelayError("bad_head")
    return head_message(pose, seq=envelope.seq, sent=envelope.time)


def _set_face(envelope: Envelope) -> Message:
    face = str(envelope.body.get("face_id", envelope.body.get("face", "")))
    if face not in FACE_IDS:
        raise RelayError("unknown_face")
    renderer = envelope.body.get("renderer")
    if renderer is not None and renderer not in RENDERERS:
        raise RelayError("unknown_renderer")
    return set_face_message(face, renderer)


def _play_audio(envelope: Envelope) -> Message:
    body = envelope.body
    prompt_id = body.get("prompt_id")
    prompt_id = prompt_id if isinstance(prompt_id, str) else None
    lipsync = body.get("lipsync_url")
    play_id = body.get("play_id")
    return play_audio_message(
        play_id
        if isinstance(play_id, str) and play_id and RELAY_PLAY_MARK not in play_id
        else f"{prompt_id or 'audio'}{RELAY_PLAY_MARK}{envelope.seq}",
        str(body["url"]),
        prompt_id=prompt_id,
        lipsync_url=lipsync if isinstance(lipsync, str) else None,
    )


def _stop_audio(_envelope: Envelope) -> Message:
    return stop_audio_message()


_CONVERTERS: dict[str, Callable[[Envelope], Message]] = {
    "face": _face, "head": _head, "set_face": _set_face, "play_audio": _play_audio,
    "stop_audio": _stop_audio,
}  # fmt: skip


def relay_envelope(
    channel: DisplayChannel,
    envelope: Envelope,
    lipsync_for: LipsyncResolver | None = None,
    served_from: str | None = None,
) -> bool:
    """Publish one worker envelope to its booth's pages; False (counted) when unusable."""
    try:
        message = display_message(envelope, lipsync_for, served_from)
        channel.publish(booth_of(envelope), message)
    except RelayError as error:
        channel.counters[f"relay.{error.reason}"] += 1
        return False
    return True


def speech_command_body(message: Message) -> dict[str, Any]:
    """The ``speech_event`` command body for a page's speech report, with the worker's own
    id of the play when it gave one."""
    body = {"event": message["event"], "prompt_id": message.get("prompt_id")}
    play_id = message.get("play_id")
    if isinstance(play_id, str) and play_id and RELAY_PLAY_MARK not in play_id:
        body["play_id"] = play_id
    return body


def forward_speech_events(channel: DisplayChannel, send_command: SendCommand) -> None:
    """Send every page speech start/end to the booth's worker: ``send_command(booth,
    "speech_event", body)`` (sync or async, e.g. the bridge's command sender)."""

    async def listener(booth: str, message: Message) -> None:
        if message.get("type") != "speech":
            return
        result = send_command(booth, SPEECH_EVENT, speech_command_body(message))
        if inspect.isawaitable(result):
            await result

    channel.add_listener(listener)
