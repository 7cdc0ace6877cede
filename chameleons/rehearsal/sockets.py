"""The WebSockets the real pages hold open, played by scripts.

- :class:`PhoneSocket` is the phone page's ``/ws/p/<token>``: the server pushes the
  phone's view whenever the session changes; the scripted participant waits on it.
- :class:`DisplayScreen` is the robot display page's ``/ws/display/<booth>``: it receives
  the virtual robot's face frames and prompt audio, and reports each prompt's speech start
  and end at once (a rehearsal does not wait for audio), which the server forwards to
  the worker, exactly as the page does after playing it.

Each reads in a thread of its own; waiting is on a condition, never on a sleep.
"""

from __future__ import annotations

import contextlib
import json
import threading
from collections import Counter
from collections.abc import Callable
from typing import Any
from urllib.parse import urlsplit

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
        """Report the prompt as spoken: start (no delay) and end, as the page does."""
        ids = {"play_id": str(play.get("play_id", "")), "prompt_id": play.get("prompt_id")}
        self._send({"type": "speech", "event": "start", "audio_delay_ms": 0.0, **ids})
        self._send({"type": "speech", "event": "end", "reason": "ended", **ids})

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
