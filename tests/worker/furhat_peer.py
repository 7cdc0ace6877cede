"""A WebSocket test peer that speaks the part of the Furhat Realtime API the worker uses.

Modelled on Furhat's own client (PyPI ``furhat-realtime-api`` 0.1.3, ``AsyncFurhatClient``
and ``events.py``) and the Realtime API documentation it links (docs.furhat.io), not on
this project's driver:

- ``request.auth`` is answered ``response.auth`` with ``access`` and ``scope``; the client
  counts only ``access: true`` as a login. ``access`` False refuses, None never answers.
- Replies echo the request's ``request_id`` (the client's ``send_event_and_wait`` matches
  replies by it); ``echo_request_id=False`` models a robot that does not.
- Speech is a queue, as on the robot: a ``request.speak.audio`` or ``request.speak.text``
  (the client's ``request_speak_text``: ``text``, ``abort``; the robot's own TTS) that
  arrives while one plays waits for it, unless it has ``abort: true``;
  ``request.speak.stop`` stops the current one and drops the queue. Each play answers
  ``response.speak.start`` after ``start_latency`` seconds and ``response.speak.end`` after
  ``speech_seconds`` more (or when stopped, with ``aborted: true``).
- ``response.speak.end`` carries ``text``, ``aborted`` and ``failed`` (booleans), the fields
  Furhat's documented speech end has (a Unity client's typed copy of the Realtime API's
  events, github.com/andre-pereira/furhat-unity-api ``Runtime/FurhatResponses.cs``,
  ``SpeakEndEvent``). Audio the robot cannot fetch (``unplayable(url)`` true: a URL on the
  server's loopback address, say) ends with ``failed: true`` and no speech, after a
  ``response.speak.start`` (``start_before_failure``, the default: the speech action starts
  and then fails; False: the end comes alone).
- ``auth_delay``: the login is answered that many seconds late (a robot still booting).
- ``request.voice.config`` (the client's ``request_voice_config``) with a ``name`` from
  ``voices`` sets the TTS voice and is answered ``response.voice.status`` (what the client
  waits for) with ``voice_id``; the sentences said in it are kept in ``said``. The answer
  to an unknown name is not documented; the peer answers ``response.error`` and keeps its
  voice.
- ``request.face.status`` answers ``face_id`` and ``face_list``.
- ``refuse_fields``: face-config fields this robot does not know. The refusal's form is not
  documented; the peer answers ``{"type": "response.error", "request_id", "error"}``.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed


@dataclass(frozen=True)
class Received:
    time: float
    message: dict[str, Any]

    @property
    def type(self) -> str:
        return str(self.message.get("type"))


class _Voice:
    """One connection's speech queue (the robot plays one audio at a time)."""

    def __init__(self, peer: FurhatPeer, ws: ServerConnection) -> None:
        self.peer, self.ws = peer, ws
        self.queue: deque[dict[str, Any]] = deque()
        self.task: asyncio.Task[None] | None = None
        self.playing: dict[str, Any] | None = None

    async def speak(self, message: dict[str, Any]) -> None:
        if message.get("abort"):
            await self.stop()
        self.queue.append(message)
        if self.task is None or self.task.done():
            self.task = asyncio.create_task(self._run())

    async def stop(self) -> None:
        self.queue.clear()
        if self.task is not None and not self.task.done():
            self.task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self.task
        if self.playing is not None:
            playing, self.playing = self.playing, None
            await self._end(playing, aborted=True)

    async def _run(self) -> None:
        while self.queue:
            message = self.queue.popleft()
            self.playing = message
            await asyncio.sleep(self.peer.start_latency)
            url = str(message.get("url"))
            failing = message.get("type") == "request.speak.audio" and self.peer.unplayable(url)
            if failing and not self.peer.start_before_failure:
                self.playing = None
                await self._end(message, failed=True)
                continue
            await self.peer.reply(self.ws, "response.speak.start", message)
            if failing:
                self.peer.failed.append(url)
                self.playing = None
                await self._end(message, failed=True)
                continue
            if message.get("type") == "request.speak.text":
                self.peer.said.append((str(message.get("text")), self.peer.voice))
            else:
                self.peer.spoken.append(url)
            await asyncio.sleep(self.peer.speech_seconds)
            self.playing = None
            await self._end(message)

    async def _end(self, message: dict[str, Any], *, aborted: bool = False,
                   failed: bool = False) -> None:  # fmt: skip
        await self.peer.reply(self.ws, "response.speak.end", message,
                              text=str(message.get("text") or ""), aborted=aborted,
                              failed=failed)  # fmt: skip


class FurhatPeer:
    def __init__(
        self, *, speech_seconds: float = 0.2, start_latency: float = 0.0,
        access: bool | None = True, echo_request_id: bool = True,
        faces: tuple[str, ...] = ("adult - Alex", "Isabel", "Marty"),
        refuse_fields: frozenset[str] = frozenset(),
        voices: tuple[str, ...] = ("Matthew-Neural", "Joanna-Neural", "Astrid"),
        unplayable: Callable[[str], bool] = lambda _url: False,
        start_before_failure: bool = True, auth_delay: float = 0.0,
    ) -> None:  # fmt: skip
        self.speech_seconds, self.start_latency = speech_seconds, start_latency
        self.unplayable, self.start_before_failure = unplayable, start_before_failure
        self.auth_delay = auth_delay
        self.failed: list[str] = []  # audio URLs the robot could not play, in order
        self.access, self.echo_request_id = access, echo_request_id
        self.faces, self.refuse_fields = faces, refuse_fields
        self.received: list[Received] = []
        self.sent: list[dict[str, Any]] = []
        self.spoken: list[str] = []  # audio URLs whose speech started, in order
        self.voices, self.voice = voices, voices[0]  # the robot's TTS voices and current one
        self.said: list[tuple[str, str]] = []  # (text, voice) whose speech started, in order
        self.connections = 0
        self._cond = threading.Condition()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._server: Server | None = None
        self._live: set[ServerConnection] = set()
        self._ready = threading.Event()
        self._stop: asyncio.Event | None = None
        self._thread = threading.Thread(target=lambda: asyncio.run(self._main()), daemon=True)
        self.port = 0

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}/v1/events"

    def __enter__(self) -> FurhatPeer:
        self._thread.start()
        assert self._ready.wait(5), "furhat peer did not start"
        return self

    def __exit__(self, *_exc: object) -> None:
        assert self._loop is not None
        assert self._stop is not None
        self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(5)

    async def _main(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        async with serve(self._handle, "127.0.0.1", 0) as server:
            self._server = server
            self.port = next(iter(server.sockets)).getsockname()[1]
            self._ready.set()
            await self._stop.wait()

    async def _handle(self, ws: ServerConnection) -> None:
        self._live.add(ws)
        voice = _Voice(self, ws)
        with self._cond:
            self.connections += 1
            self._cond.notify_all()
        try:
            async for raw in ws:
                message = json.loads(raw)
                with self._cond:
                    self.received.append(Received(time.monotonic(), message))
                    self._cond.notify_all()
                await self._answer(ws, voice, message)
        except ConnectionClosed:
            pass
        finally:
            if voice.task is not None:
                voice.task.cancel()
            self._live.discard(ws)

    async def reply(self, ws: ServerConnection, kind: str, request: dict[str, Any],
                    **fields: Any) -> None:  # fmt: skip
        message: dict[str, Any] = {"type": kind, **fields}
        if self.echo_request_id and "request_id" in request:
            message["request_id"] = request["request_id"]
        with self._cond:
            self.sent.append(message)
            self._cond.notify_all()
        with contextlib.suppress(ConnectionClosed):
            await ws.send(json.dumps(message))

    async def _answer(self, ws: ServerConnection, voice: _Voice, message: dict[str, Any]) -> None:
        kind = message.get("type")
        if kind == "request.auth":
            await asyncio.sleep(self.auth_delay)
            if self.access is not None:
                await self.reply(ws, "response.auth", message, access=self.access,
                                 scope="local_network" if self.access else None)  # fmt: skip
        elif kind in ("request.speak.audio", "request.speak.text"):
            await voice.speak(message)
        elif kind == "request.voice.config":
            await self._configure_voice(ws, message)
        elif kind == "request.speak.stop":
            await voice.stop()
        elif kind == "request.face.status":
            await self.reply(ws, "response.face.status", message, face_id=self.faces[0],
                             face_list=list(self.faces))  # fmt: skip
        elif kind == "request.face.config":
            unknown = sorted(set(message) & self.refuse_fields)
            if unknown:
                await self.reply(ws, "response.error", message,
                                 error=f"unknown field {unknown[0]}")  # fmt: skip

    async def _configure_voice(self, ws: ServerConnection, message: dict[str, Any]) -> None:
        name = message.get("name") or message.get("voice_id")
        if name not in self.voices:
            await self.reply(ws, "response.error", message, error=f"unknown voice {name}")
            return
        self.voice = str(name)
        await self.reply(ws, "response.voice.status", message, voice_id=self.voice,
                         voice_list=list(self.voices))  # fmt: skip

    def drop_connections(self) -> None:
        """Close every live connection from the robot's side (the driver must reconnect)."""
        assert self._loop is not None
        for ws in list(self._live):
            asyncio.run_coroutine_threadsafe(ws.close(), self._loop).result(5)

    def of_type(self, kind: str) -> list[Received]:
        with self._cond:
            return [r for r in self.received if r.type == kind]

    def sent_of_type(self, kind: str) -> list[dict[str, Any]]:
        with self._cond:
            return [m for m in self.sent if m.get("type") == kind]

    def wait_for(self, predicate: Callable[[FurhatPeer], bool], timeout: float = 5.0) -> None:
        with self._cond:
            if not self._cond.wait_for(lambda: predicate(self), timeout):
                kinds = [r.type for r in self.received[-5:]]
                raise AssertionError(f"furhat peer: condition not met; last received {kinds}")
