"""The WebSockets the real pages hold open, played by scripts.

- :class:`PhoneSocket` is the phone page's ``/ws/p/<token>``: the server pushes the
  phone's view whenever the session changes; the scripted participant waits on it.
- :class:`DisplayScreen` is the robot display page's ``/ws/display/<booth>``: it receives
  the virtual robot's face frames and prompt audio, loads each prompt's audio (and curves)
  from the URL the page would, and reports the prompt's speech start and end at once (a
  rehearsal does not wait for audio), or, when the audio cannot be loaded, the end with
  the page's ``error`` reason; the server forwards them to the worker, exactly as the page
  does after playing it.

Each reads in a thread of its own; waiting is on a condition, never on a sleep.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import threading
from collections import Counter
from collections.abc import Callable
from typing import Any
from urllib.parse import urlsplit

import httpx
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect

Json = dict[str, Any]


def websocket_url(base_url: str, path: str) -> str:
    parts = urlsplit(base_url)
    scheme = "wss" if parts.scheme == "https" else "ws"
    return f"{scheme}://{parts.netloc}{path}"


class _Reader:
    """A connection whose messages a thread hands to ``_on_message``."""

    def __init__(self, connection: ClientConnection, name: str) -> None:
        self._connection = connection
        self._condition = threading.Condition()
        self.closed = False
        self._thread = threading.Thread(target=self._read, name=name, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        try:
            for text in self._connection:
                message = json.loads(text)
                if isinstance(message, dict):
                    self._on_message(message)
        except (ConnectionClosed, OSError, ValueError):
            pass
        finally:
            with self._condition:
                self.closed = True
                self._condition.notify_all()

    def _on_message(self, message: Json) -> None:
        raise NotImplementedError

    def _send(self, message: Json) -> None:
        # A closed socket: the page went away, the server logs the missing events.
        with contextlib.suppress(ConnectionClosed, OSError):
            self._connection.send(json.dumps(message, separators=(",", ":")))

    def close(self) -> None:
        self._connection.close()
        self._thread.join(timeout=5)


class PhoneSocket(_Reader):
    """The phone page's socket: the latest view the server pushed."""

    def __init__(self, base_url: str, token: str, *, proxy: bool = True) -> None:
        url = websocket_url(base_url, f"/ws/p/{token}")
        self.state: Json | None = None
        self.updates = 0
        super().__init__(connect(url, proxy=True if proxy else None), "rehearsal-phone")

    def _on_message(self, message: Json) -> None:
        if message.get("type") == "state" and isinstance(message.get("state"), dict):
            with self._condition:
                self.state = message["state"]
                self.updates += 1
                self._condition.notify_all()

    def wait_for(self, wanted: Callable[[Json], bool], what: str, timeout: float = 10.0) -> Json:
        """The first pushed view (or the current one) for which ``wanted`` holds."""
        with self._condition:
            self._condition.wait_for(
                lambda: self.closed or (self.state is not None and wanted(self.state)), timeout
            )
            if self.state is not None and wanted(self.state):
                return self.state
        shown = self.state.get("view") if self.state else None
        reason = "the socket closed" if self.closed else f"after {timeout:g} s"
        raise TimeoutError(f"the phone never showed {what} ({reason}; it shows {shown!r})")


class DisplayScreen(_Reader):
    """The robot display page: counts what the virtual robot sends, answers its audio."""

    def __init__(self, base_url: str, booth: str, cookie: str, *, proxy: bool = True) -> None:
        url = websocket_url(base_url, f"/ws/display/{booth}")
        origin = base_url.rstrip("/")
        connection = connect(
            url,
            origin=origin,  # type: ignore[arg-type]  # a plain str is what the header carries
            additional_headers={"Cookie": cookie},
            proxy=True if proxy else None,
        )
        self.received: Counter[str] = Counter()
        self.faces: list[str] = []
        self.voiced = 0  # prompts whose audio loaded (and was reported spoken)
        self.unloaded: list[str] = []  # "prompt_id: why" of audio that did not load
        self.fetched: list[tuple[str, str, str]] = []  # (prompt id, URL path, sha256)
        self._media = httpx.Client(base_url=origin, timeout=30, trust_env=proxy)
        super().__init__(connection, "rehearsal-display")

    def _on_message(self, message: Json) -> None:
        kind = str(message.get("type"))
        with self._condition:
            self.received[kind] += 1
            if kind == "set_face":
                self.faces.append(str(message.get("face")))
            self._condition.notify_all()
        if kind == "play_audio":
            self._speak(message)

    def _speak(self, play: Json) -> None:
        """Load the prompt's audio and curves as the page does, then report it spoken:
        start (no delay) and end; audio that does not load ends with ``error``."""
        ids = {"play_id": str(play.get("play_id", "")), "prompt_id": play.get("prompt_id")}
        problem = self._load(str(ids["prompt_id"]), play.get("url"), audio=True)
        problem = problem or self._load(str(ids["prompt_id"]), play.get("lipsync_url"))
        if problem is not None:
            with self._condition:
                self.unloaded.append(f"{ids['prompt_id']}: {problem}")
            self._send({"type": "speech", "event": "end", "reason": "error", **ids})
            with self._condition:
                self._condition.notify_all()
            return
        self._send({"type": "speech", "event": "start", "audio_delay_ms": 0.0, **ids})
        self._send({"type": "speech", "event": "end", "reason": "ended", **ids})
        with self._condition:
            self.voiced += 1
            self._condition.notify_all()

    def wait_for_answered(self, count: int, timeout: float = 60.0) -> bool:
        """Whether ``count`` prompts were answered (voiced, or their audio did not load)
        within ``timeout``: the last play of a run may still be on its way or loading."""
        with self._condition:
            return self._condition.wait_for(
                lambda: self.closed or self.voiced + len(self.unloaded) >= count, timeout
            ) and (self.voiced + len(self.unloaded) >= count)

    def _load(self, prompt_id: str, url: object, *, audio: bool = False) -> str | None:
        """Why ``url`` could not be loaded, or None (no URL: nothing to load, as for curves
        the prompt has none of; an empty audio URL is a prompt without a recording)."""
        if not isinstance(url, str) or not url:
            return "the prompt has no audio" if audio else None
        try:
            response = self._media.get(url)  # a path: from the server the page came from
        except httpx.HTTPError as error:
            return f"{urlsplit(url).path}: {error}"
        if response.status_code != httpx.codes.OK or not response.content:
            return f"{urlsplit(url).path}: HTTP {response.status_code}"
        if audio:
            digest = hashlib.sha256(response.content).hexdigest()
            with self._condition:
                self.fetched.append((prompt_id, urlsplit(url).path, digest))
        return None

    def close(self) -> None:
        super().close()
        self._media.close()

    def wait_for_received(self, kind: str, count: int, timeout: float = 60.0) -> bool:
        """Whether ``count`` messages of ``kind`` have arrived within ``timeout`` (the last
        play of a run may still be on its way when the sessions end)."""
        with self._condition:
            return self._condition.wait_for(
                lambda: self.closed or self.received[kind] >= count, timeout
            ) and (self.received[kind] >= count)

    def wait_for_frames(self, count: int, timeout: float = 10.0) -> bool:
        """Whether ``count`` face frames of the virtual robot arrived within ``timeout``."""
        with self._condition:
            return (
                self._condition.wait_for(
                    lambda: self.closed or self.received["face"] >= count, timeout
                )
                and self.received["face"] >= count
            )
