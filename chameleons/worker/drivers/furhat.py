"""``furhat``: the Furhat Realtime API over WebSocket (protocols.md section 4a).

Checked against Furhat's own client (PyPI ``furhat-realtime-api`` 0.1.3,
``AsyncFurhatClient``; see docs/furhat.md):

- **Authentication.** The login succeeds only when ``response.auth`` has ``access: true``
  (the vendor's ``connect`` raises otherwise), answered within ``auth_timeout`` (5 s, the
  vendor's ``send_event_and_wait`` default). A refusal stops the driver in state
  ``auth_refused`` with the reason: a wrong key does not fix itself, so it sends nothing
  and does not retry until :meth:`retry` (the wizard's button) or a new worker
  configuration (a restart). No answer (``auth_timeout``: a robot still booting) is
  retried with backoff, like a robot that cannot be reached, and the state says when the
  next try is (``retry_in``, also in :meth:`stats`). Retrying happens only while the
  driver is not logged in, so never during a prompt; one played meanwhile ends at once,
  not voiced, with the reason.
- **Face set-up.** ``request.face.config`` carries only the fields the vendor's client
  sends (``face_id``, ``visibility``, ``microexpressions``). ``blinking`` and
  ``head_sway`` are not in it: each goes in a message of its own, so a robot that refuses
  one cannot lose the chosen face with it; a refusal is kept in ``stats()["refused"]``.
- **Speech.** See :mod:`.furhat_speech`. A ``response.speak.end`` with ``failed: true``
  ends the play ``failed`` with the reason (the URL the robot could not play, and a hint
  when that URL names the server's loopback address, which no robot elsewhere can reach).
  Typed speech (the wizard's fallback sentence) is
  ``request.speak.text`` (the vendor's ``request_speak_text``: ``text``, ``abort``) with a
  ``request_id``, tracked like audio; a voice the study names for the actor is set first
  with ``request.voice.config`` (``request_voice_config``'s ``name``), else the robot's
  current voice speaks.

The renderer's calls only append to bounded deques and wake the sender; one asyncio task in
the driver's own thread drains them, so a slow or absent robot never blocks a tick. Face
frames and head poses that pile up are stale: only the newest of each is sent (the rest are
counted as dropped). The connection is retried with exponential backoff; its state is
reported as an event (``connecting``, ``connected``, ``disconnected``, ``closed``).

The study's face ids (``face-1``..) mean nothing to a real robot: ``faces`` maps them to the
robot's own face names. An id it does not list is sent unchanged, warned about once, and
shown in ``stats()`` (``unmapped_face``) so the wizard sees it in the booth's telemetry.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import threading
import time
from collections import deque
from collections.abc import Mapping
from typing import Any

import numpy as np
from websockets.asyncio.client import ClientConnection, connect
from websockets.exceptions import WebSocketException

from chameleons.worker.drivers.base import SPEECH_END, SPEECH_START, Driver
from chameleons.worker.drivers.furhat_messages import (
    UNCERTAIN_FACE_FIELDS,
    auth_request,
    decode,
    face_config,
    face_params,
    field_request,
    headpose,
)
from chameleons.worker.drivers.furhat_speech import (
    FAILED,
    Credit,
    SpeechTracker,
    failure_reason,
)
from chameleons.worker.frames import BLENDSHAPE_INDEX, BLENDSHAPE_NAMES, F32Array, upper_snake

log = logging.getLogger(__name__)
DEFAULT_URL = "ws://127.0.0.1:9000/v1/events"
# TONGUE_OUT is not confirmed to exist on the robot's ARKit face: left out unless asked for.
DEFAULT_EXCLUDED = ("tongueOut",)
AUTH_REFUSED, AUTH_TIMEOUT = "auth_refused", "auth_timeout"
AUTH_TIMEOUT_S = 5.0  # the vendor's client waits 5 s for ``response.auth``


class AuthFailedError(Exception):
    def __init__(self, state: str, reason: str) -> None:
        super().__init__(reason)
        self.state, self.reason = state, reason


class FurhatDriver(Driver):
    name = "furhat"
    speaks_text = True

    def __init__(
        self, url: str = DEFAULT_URL, *, key: str | None = None, face_id: str | None = None,
        faces: Mapping[str, str] | None = None, excluded: tuple[str, ...] = DEFAULT_EXCLUDED,
        backoff_initial: float = 0.25, backoff_max: float = 8.0,
        auth_timeout: float = AUTH_TIMEOUT_S,
        queue_size: int = 8,
    ) -> None:  # fmt: skip
        super().__init__()
        self.url, self.key = url, key
        self.faces = dict(faces or {})
        self._warned_faces: set[str] = set()
        self.unmapped_face: str | None = None
        self.face_id: str | None = None
        self.robot_face_id: str | None = None  # what the robot is told: face_id, mapped
        self._select_face(face_id)
        self.backoff_initial, self.backoff_max, self.auth_timeout = (
            backoff_initial, backoff_max, auth_timeout,
        )  # fmt: skip
        kept = [n for n in BLENDSHAPE_NAMES if n not in excluded]
        self._indices = np.array([BLENDSHAPE_INDEX[n] for n in kept])
        self._names = tuple(upper_snake(n) for n in kept)
        self._stream: deque[tuple[str, Any]] = deque(maxlen=queue_size)
        self._control: deque[dict[str, Any]] = deque(maxlen=64)
        self.speech = SpeechTracker()
        self.voice: str | None = None  # the TTS voice last set on this connection
        self.problem: str | None = None  # why the login failed (auth), for the wizard
        self._retry_at: float | None = None  # monotonic time of the next connection attempt
        self.refused: dict[str, str] = {}  # uncertain face field -> the robot's refusal
        self._pending_fields: dict[str, str] = {}  # request_id -> uncertain field
        self._retry = threading.Event()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._wake: asyncio.Event | None = None
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None
        self.dropped = 0
        self.connects = 0

    # --- called from the renderer's thread -------------------------------------------------
    def start(self) -> None:
        self.set_state("connecting")
        self._thread = threading.Thread(target=self._thread_main, name="furhat-driver", daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stopping.set()
        self._notify()
        if self._thread is not None:
            self._thread.join(timeout=5)
        self.set_state("closed")

    def send_face(self, blendshapes: F32Array) -> None:
        if self.problem is not None:  # refused: nothing goes to the robot until a retry
            return
        self._queue_stream("face", blendshapes[self._indices])
        self.faces_sent += 1

    def send_head(self, yaw: float, pitch: float, roll: float) -> None:
        if self.problem is not None:
            return
        self._queue_stream("head", (yaw, pitch, roll))
        self.heads_sent += 1

    def retry(self) -> None:
        """Try the robot again after a refused or unanswered login (the wizard asked)."""
        self._retry.set()
        self._notify()

    def play_audio(self, prompt_id: str, url: str, play_id: str | None = None) -> None:
        # The worker drives the mouth from the prompt's curves: the robot's lip-sync is off.
        request = {"type": "request.speak.audio", "url": url, "lipsync": False}
        self._speak(prompt_id, request, play_id)

    def speak_text(
        self, prompt_id: str, text: str, voice: str | None, play_id: str | None = None
    ) -> None:
        """Typed speech in the robot's own TTS (its own lip-sync: no curves come with it)."""
        if voice and voice != self.voice and self.connected:
            self.voice = voice  # kept: the robot stays in this voice until told otherwise
            self._queue_control({"type": "request.voice.config", "name": voice})
        self._speak(prompt_id, {"type": "request.speak.text", "text": text}, play_id)

    def _speak(self, prompt_id: str, request: dict[str, Any], play_id: str | None) -> None:
        """Send one speech request, tracked by ``request_id``; one under way is stopped."""
        if not self.connected:  # nothing will ever answer: end the speech at once
            self.emit(SPEECH_END, prompt_id=prompt_id, play_id=play_id, outcome="skipped",
                      error=self._absence())  # fmt: skip
            return
        busy, stopped = self.speech.busy, self.speech.stopped
        play, replaced = self.speech.begin(prompt_id, play_id, str(request.get("url") or ""))
        if busy and not stopped:  # the robot would queue it behind the one that plays
            self._queue_control({"type": "request.speak.stop"})
        # A play the wizard has just stopped (the stop went out) counts as under way whether
        # or not the robot's end has come back yet: the flag must not depend on that race.
        abort = busy or stopped
        self._queue_control({**request, "abort": abort, "request_id": play.request_id})
        self._credit(replaced)

    def stop_audio(self) -> None:
        # Marked as stopping before the request goes out: the robot's end event can come
        # back on the receiving thread before this one runs again (then it read "played").
        credit = self.speech.stop()
        self._queue_control({"type": "request.speak.stop"})
        self._credit(credit)

    def set_face(self, face_id: str, renderer: str | None = None) -> None:
        self._select_face(face_id)
        self._queue_control(self._face_config())

    def stats(self) -> dict[str, Any]:
        return {**super().stats(), "dropped": self.dropped, "connects": self.connects,
                "face_id": self.face_id, "robot_face_id": self.robot_face_id,
                "unmapped_face": self.unmapped_face, "problem": self.problem,
                "refused": dict(self.refused), "voice": self.voice,
                "speech_swallowed": self.speech.swallowed,
                "retry_in": self._retry_in()}  # fmt: skip

    def _absence(self) -> str:
        """Why nothing can be said now, and when the robot is tried again."""
        why = self.problem or "robot not connected"
        retry_in = self._retry_in()
        return why if retry_in is None else f"{why}; retrying in {retry_in:.0f} s"

    def _retry_in(self) -> float | None:
        """Seconds to the next connection attempt (None: not waiting to retry)."""
        at = self._retry_at
        return None if at is None else round(max(0.0, at - time.monotonic()), 1)

    def _credit(self, credit: Credit | None) -> None:
        if credit is None:
            return
        if credit.kind == "start":
            self.emit(SPEECH_START, prompt_id=credit.prompt_id, play_id=credit.play_id)
        elif credit.outcome == FAILED:
            self.emit(SPEECH_END, prompt_id=credit.prompt_id, play_id=credit.play_id,
                      outcome=FAILED, error=failure_reason(credit, self.voice))  # fmt: skip
        else:
            self.emit(SPEECH_END, prompt_id=credit.prompt_id, play_id=credit.play_id,
                      outcome=credit.outcome)  # fmt: skip

    def _select_face(self, face_id: str | None) -> None:
        self.face_id = face_id
        if not face_id:
            self.robot_face_id = self.unmapped_face = None
            return
        mapped = self.faces.get(face_id)
        self.robot_face_id = mapped or face_id
        self.unmapped_face = None if mapped else face_id
        if not mapped and face_id not in self._warned_faces:
            self._warned_faces.add(face_id)
            log.warning(
                "furhat: no robot face mapped for %r (--furhat-face, "
                "CHAMELEONS_WORKER_FURHAT_FACES); sending it unchanged", face_id,
            )  # fmt: skip

    def _queue_stream(self, kind: str, data: Any) -> None:
        if len(self._stream) == self._stream.maxlen:
            self.dropped += 1
        self._stream.append((kind, data))
        self._notify()

    def _queue_control(self, message: dict[str, Any]) -> None:
        self._control.append(message)
        self._notify()

    def _notify(self) -> None:
        loop, wake = self._loop, self._wake
        if loop is not None and wake is not None:
            with contextlib.suppress(RuntimeError):  # the loop is closing
                loop.call_soon_threadsafe(wake.set)

    # --- the driver's own thread -----------------------------------------------------------
    def _thread_main(self) -> None:
        asyncio.run(self._main())

    async def _main(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._wake = asyncio.Event()
        delay = self.backoff_initial
        while not self._stopping.is_set():
            self.set_state("connecting")
            state, detail = "disconnected", {}
            try:
                async with connect(self.url, open_timeout=self.auth_timeout) as ws:
                    await self._handshake(ws)
                    delay = self.backoff_initial
                    await self._session(ws)
            except AuthFailedError as exc:
                if exc.state == AUTH_REFUSED:  # a wrong key: only the wizard can fix it
                    await self._halt(exc)
                    delay = self.backoff_initial
                    continue
                # Not answered: a robot still booting answers later. Retried with backoff.
                log.warning("furhat at %s: %s; retrying in %g s", self.url, exc.reason, delay)
                self.problem = exc.reason
                state, detail = exc.state, {"reason": exc.reason}
            except (OSError, TimeoutError, WebSocketException, ValueError) as exc:
                log.info("furhat connection to %s failed: %s", self.url, exc)
            self._pending_fields.clear()
            credit = self.speech.drop_all()  # a prompt that was playing will never end
            if credit is not None:
                self.emit(SPEECH_END, prompt_id=credit.prompt_id, play_id=credit.play_id,
                          outcome=credit.outcome, error="robot disconnected")  # fmt: skip
            if self._stopping.is_set():
                break
            self._retry_at = time.monotonic() + delay
            self.set_state(state, retry_in=delay, **detail)
            await self._sleep(delay)
            self._retry_at = None
            delay = min(delay * 2, self.backoff_max)

    async def _halt(self, failure: AuthFailedError) -> None:
        """Refused or unanswered login: report it and wait for the wizard's retry."""
        log.warning("furhat at %s: %s; not retrying until asked", self.url, failure.reason)
        self.problem = failure.reason
        self._retry.clear()
        self.set_state(failure.state, reason=failure.reason)
        assert self._wake is not None
        while not (self._stopping.is_set() or self._retry.is_set()):
            self._wake.clear()
            await self._wake.wait()
        self._retry.clear()

    async def _sleep(self, seconds: float) -> None:
        """Wait ``seconds``, less when closing or when the wizard asks for a retry."""
        assert self._wake is not None
        end = asyncio.get_running_loop().time() + seconds
        while not self._stopping.is_set():
            if self._retry.is_set():
                self._retry.clear()
                return
            remaining = end - asyncio.get_running_loop().time()
            if remaining <= 0:
                return
            self._wake.clear()
            try:
                await asyncio.wait_for(self._wake.wait(), remaining)
            except TimeoutError:
                return

    def _face_config(self) -> dict[str, Any]:
        return face_config(self.robot_face_id)

    def _uncertain_fields(self) -> list[dict[str, Any]]:
        """One message per field the vendor's client does not send (not yet refused)."""
        messages = []
        for name in UNCERTAIN_FACE_FIELDS:
            if name in self.refused:
                continue
            request_id = f"{name}-{self.connects}"
            self._pending_fields[request_id] = name
            messages.append(field_request(name, request_id))
        return messages

    async def _handshake(self, ws: ClientConnection) -> None:
        await ws.send(json.dumps(auth_request(self.key)))
        try:
            async with asyncio.timeout(self.auth_timeout):
                while True:
                    reply = decode(await ws.recv())
                    if reply.get("type") == "response.auth":
                        break
        except TimeoutError:
            raise AuthFailedError(AUTH_TIMEOUT, f"the robot did not answer the login within "
                             f"{self.auth_timeout:g} s") from None  # fmt: skip
        if reply.get("access") is not True:  # the only success the vendor's client knows
            detail = reply.get("message") or reply.get("error") or "wrong or missing key"
            raise AuthFailedError(AUTH_REFUSED, f"the robot refused the login ({detail})")
        self.problem = None
        # Whatever queued while disconnected is stale: the config below carries the current
        # face. Clear first: a set_face arriving during the send stays queued (not dropped).
        self._stream.clear()
        self._control.clear()
        self.connects += 1
        self.voice = None  # a restarted robot may speak in its default voice again
        await ws.send(json.dumps(self._face_config()))
        for message in self._uncertain_fields():
            await ws.send(json.dumps(message))
        self.set_state("connected")

    async def _session(self, ws: ClientConnection) -> None:
        sender = asyncio.create_task(self._send_loop(ws))
        receiver = asyncio.create_task(self._receive_loop(ws))
        done, pending = await asyncio.wait({sender, receiver}, return_when="FIRST_COMPLETED")
        for task in pending:
            task.cancel()
        await asyncio.gather(*pending, return_exceptions=True)
        for task in done:
            task.result()  # re-raise a connection error for the caller

    async def _send_loop(self, ws: ClientConnection) -> None:
        assert self._wake is not None
        while not self._stopping.is_set():
            await self._wake.wait()
            self._wake.clear()
            while self._control:
                await ws.send(json.dumps(self._control.popleft()))
            latest: dict[str, Any] = {}
            while self._stream:
                kind, data = self._stream.popleft()
                if kind in latest:
                    self.dropped += 1  # stale: a newer one is queued
                latest[kind] = data
            for kind, data in latest.items():
                await ws.send(self._stream_message(kind, data))

    def _stream_message(self, kind: str, data: Any) -> str:
        if kind == "head":
            yaw, pitch, roll = data
            return headpose(yaw, pitch, roll)
        return face_params(self._names, data)

    async def _receive_loop(self, ws: ClientConnection) -> None:
        async for raw in ws:
            message = decode(raw)
            kind = str(message.get("type", ""))
            request_id = message.get("request_id")
            if kind in ("response.speak.start", "response.speak.end"):
                detail = message.get("error") or message.get("message")
                self._credit(self.speech.on_message(
                    kind, request_id, failed=message.get("failed") is True,
                    aborted=message.get("aborted") is True,
                    detail=str(detail) if detail else None))  # fmt: skip
            elif isinstance(request_id, str) and request_id in self._pending_fields:
                self._field_answer(self._pending_fields.pop(request_id), kind, message)

    def _field_answer(self, name: str, kind: str, message: dict[str, Any]) -> None:
        """A reply to an uncertain face field: an error is a refusal, kept and shown."""
        error = message.get("error") or message.get("message")
        if kind.endswith("error") or message.get("success") is False or error:
            self.refused[name] = str(error or kind)
            log.warning("furhat refused face field %r: %s", name, self.refused[name])
