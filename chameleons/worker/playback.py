"""Playback: plays a prompt, stops it, and relays the robot display's speech events.

``play_prompt`` loads the prompt's lip-sync curves (:func:`load_lipsync`) and publishes
``playback.prompt`` (body ``{"prompt_id", "play_id", "audio_url", "channels", "rows"}``;
``play_id`` is the server's id of this play, which every speech event of it carries; payload the
curve times then the ``rows x len(LIPSYNC_NAMES)`` values, float32). The renderer, which owns
the driver, tells the robot to play the audio and runs the curves on the audio's clock:
from the moment the driver reports that the audio started (``speech_start``, with the
worker's timestamp) to when it ended (``speech_end``). ``stop_prompt`` publishes
``playback.stop``; ``set_face`` ``playback.face``; ``speech_event`` (sent by the server for
the virtual robot, whose page plays the audio) ``playback.speech``.

A ``play_prompt`` with ``text`` (the wizard's typed sentence) is for a robot that speaks
text with its own TTS (a Furhat, ``speaks_text``): ``playback.prompt`` then carries
``text`` and ``voice`` and no curves. Another robot refuses it (``no_tts``): the server
sends such a robot audio it synthesised.
"""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Mapping
from typing import Any

import numpy as np
import zmq

from chameleons.worker.control import (
    DISPLAY_RENDERERS,
    PLAY_PROMPT,
    RETRY_ROBOT,
    SET_FACE,
    SPEECH_EVENT,
    STOP_PROMPT,
    CommandError,
)
from chameleons.worker.envelope import Message
from chameleons.worker.lipsync import LIPSYNC_NAMES, LipSync, LipSyncError, load_lipsync
from chameleons.worker.stage import POLL_MS, CommandPort, Endpoints, send_message

__all__ = ["LipSync", "LipSyncError", "PlaybackStage", "lipsync_from_message", "load_lipsync"]


def lipsync_message(
    prompt_id: str, audio_url: str, lipsync: LipSync | None, play_id: str | None = None
) -> Message:
    body: dict[str, Any] = {"prompt_id": prompt_id, "play_id": play_id, "audio_url": audio_url,
                            "rows": 0, "channels": []}  # fmt: skip
    payload = b""
    if lipsync is not None:
        body["rows"], body["channels"] = len(lipsync.times), list(lipsync.channels)
        payload = np.concatenate([lipsync.times, lipsync.values.ravel()]).astype("<f4").tobytes()
    return Message("playback.prompt", "prompt", 0, "playback", 0.0, body, payload)


def lipsync_from_message(message: Message) -> LipSync | None:
    """Inverse of :func:`lipsync_message`'s curves (None for a prompt without lip-sync)."""
    rows = int(message.body.get("rows", 0))
    if rows == 0:
        return None
    data = message.array()
    width = len(LIPSYNC_NAMES)
    if data.size != rows * (1 + width):
        raise ValueError(f"lip-sync payload has {data.size} values for {rows} rows")
    times = data[:rows].astype(np.float64)
    values = data[rows:].reshape(rows, width)
    return LipSync(times, values, tuple(message.body.get("channels", ())))


class PlaybackStage:
    name = "playback"

    def __init__(
        self, context: zmq.Context[zmq.Socket[bytes]], endpoints: Endpoints,
        *, speaks_text: bool = False, renderers: tuple[str, ...] = DISPLAY_RENDERERS,
        driver: str = "",
    ) -> None:  # fmt: skip
        """``renderers``: the condition renderers this booth's robot can run (``furhat``
        only where it drives a Furhat); ``driver``: its name, for the refusal."""
        self.context, self.endpoints = context, endpoints
        self.speaks_text = speaks_text
        self.renderers, self.driver = renderers, driver
        self.errors: Counter[str] = Counter()
        self.prompts = 0
        self._pub: zmq.Socket[bytes] | None = None

    def run(self, stop: threading.Event) -> None:
        self._pub = self.context.socket(zmq.PUB)
        self._pub.setsockopt(zmq.LINGER, 0)
        self._pub.bind(self.endpoints.playback)
        handlers = {PLAY_PROMPT: self._play, STOP_PROMPT: self._stop, SET_FACE: self._face,
                    SPEECH_EVENT: self._speech, RETRY_ROBOT: self._retry}  # fmt: skip
        port = CommandPort(self.context, self.endpoints.stage_control, self.name, handlers)
        try:
            while not stop.is_set():
                if port.socket.poll(POLL_MS):
                    port.handle_pending()
        finally:
            self._pub.close(linger=0)
            port.close()

    def _publish(self, message: Message) -> None:
        assert self._pub is not None
        if not send_message(self._pub, message):
            self.errors["publish_dropped"] += 1

    def _play(self, body: Mapping[str, Any]) -> Mapping[str, Any]:
        if "text" in body:
            return self._say(body)
        path = body.get("lipsync_path")
        try:
            lipsync = load_lipsync(path) if path else None
        except LipSyncError as exc:
            raise CommandError("bad_lipsync", str(exc)) from exc
        prompt_id, url = str(body["prompt_id"]), str(body["audio_url"])
        play_id = body.get("play_id") or None
        self._publish(lipsync_message(prompt_id, url, lipsync, play_id))
        self.prompts += 1
        if lipsync is None:
            return {"prompt_id": prompt_id, "play_id": play_id, "lipsync_seconds": None,
                    "lipsync_channels": []}  # fmt: skip
        return {"prompt_id": prompt_id, "play_id": play_id, "lipsync_seconds": lipsync.duration,
                "lipsync_channels": list(lipsync.channels)}  # fmt: skip

    def _say(self, body: Mapping[str, Any]) -> Mapping[str, Any]:
        """Typed speech for the robot's own TTS (the renderer hands it to the driver)."""
        if not self.speaks_text:
            raise CommandError("no_tts", "this booth's robot has no text-to-speech of its own")
        prompt_id, text = str(body["prompt_id"]), str(body["text"]).strip()
        if not text:
            raise CommandError("bad_field", "text is empty")
        message = lipsync_message(prompt_id, "", None)
        message.body.update(text=text, voice=body.get("voice"))
        self._publish(message)
        self.prompts += 1
        return {"prompt_id": prompt_id, "lipsync_seconds": None, "lipsync_channels": [],
                "robot_tts": True}  # fmt: skip

    def _stop(self, _body: Mapping[str, Any]) -> Mapping[str, Any]:
        self._publish(Message("playback.stop", "stop", 0, self.name))
        return {}

    def _face(self, body: Mapping[str, Any]) -> Mapping[str, Any]:
        renderer = body.get("renderer")
        if renderer == "furhat" and renderer not in self.renderers:
            raise CommandError("bad_renderer", f"this booth drives no Furhat (its worker's "
                               f"driver is {self.driver or 'not a Furhat'}): a furhat "
                               "condition needs a worker started with --driver furhat or "
                               "--driver virtual+furhat")  # fmt: skip
        if renderer not in (None, *self.renderers):
            raise CommandError("bad_renderer", f"renderer is 2d, 3d or furhat, got {renderer!r}")
        self._publish(Message("playback.face", "face", 0, self.name, body=dict(body)))
        result = {"face_id": body["face_id"]}
        if renderer is not None:
            result["renderer"] = renderer
        return result

    def _retry(self, _body: Mapping[str, Any]) -> Mapping[str, Any]:
        self._publish(Message("playback.retry", "retry", 0, self.name))
        return {}

    def _speech(self, body: Mapping[str, Any]) -> Mapping[str, Any]:
        self._publish(Message("playback.speech", "speech", 0, self.name, body=dict(body)))
        return {}
