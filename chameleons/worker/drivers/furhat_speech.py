"""Which prompt a Furhat speech event belongs to (no I/O: the driver feeds it messages).

Furhat's own Realtime API client (PyPI ``furhat-realtime-api`` 0.1.3,
``AsyncFurhatClient.send_event_and_wait``) gives each request a ``request_id`` and takes
only the reply that carries the same id as its answer; ``request_speak_audio`` has an
``abort`` flag and ``request_speak_stop`` "stops speaking and/or aborts any planned
speech". A robot queues a ``request.speak.audio`` that arrives while it speaks, so the
tracker works the same way:

- every play gets a ``request_id``; a play sent while another is still under way is
  preceded by ``request.speak.stop`` and sent with ``abort: true`` (also right after the
  wizard stopped one, which sent its own stop, whether or not the robot's end is back);
- ``response.speak.start``/``end`` carrying a ``request_id`` are credited to that play
  only. One without an id (a robot that does not echo it) can only be placed by order:
  everything before the current play was aborted, so a start goes to the current play
  if it has not started, an end to it only once it has started (an end before the new
  play's start is the aborted one's);
- a play replaced before it started is ``skipped``, one replaced while speaking is
  ``interrupted``: neither is ever reported as played, and the robot's late events for
  it are swallowed so they cannot end the new prompt.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass

PLAYED, INTERRUPTED, SKIPPED, STOPPED = "played", "interrupted", "skipped", "stopped"


@dataclass
class Play:
    prompt_id: str
    request_id: str
    play_id: str | None = None  # the server's id of this play (its events carry it)
    started: bool = False
    stopping: bool = False  # the wizard stopped it: its end is not "played"
    outcome: str | None = None  # set once the play is over (or replaced)


@dataclass(frozen=True)
class Credit:
    """A speech event for the renderer: ``kind`` is ``start`` or ``end``."""

    kind: str
    prompt_id: str
    outcome: str | None = None
    play_id: str | None = None


class SpeechTracker:
    def __init__(self) -> None:
        self.current: Play | None = None
        self._by_id: dict[str, Play] = {}
        self.swallowed = 0  # robot events of replaced plays, not credited to anyone
        self.replaced: list[Play] = []  # recent replaced plays (for logs and tests)

    @property
    def busy(self) -> bool:
        """A play is under way: a new one must stop/abort it first."""
        return self.current is not None and self.current.outcome is None

    @property
    def stopped(self) -> bool:
        """The current play was stopped by the wizard (its stop request went out)."""
        return self.current is not None and self.current.stopping

    def begin(self, prompt_id: str, play_id: str | None = None) -> tuple[Play, Credit | None]:
        """A new play; the replaced play's credit when it never started (``skipped``: the
        renderer has not heard of it speaking, so nobody else will end it)."""
        credit = None
        old = self.current
        if old is not None and old.outcome is None:
            old.outcome = INTERRUPTED if old.started else SKIPPED
            self.replaced = [*self.replaced[-15:], old]
            if not old.started:
                credit = Credit("end", old.prompt_id, SKIPPED, old.play_id)
        play = Play(prompt_id, uuid.uuid4().hex, play_id)
        self.current = play
        self._by_id[play.request_id] = play
        return play, credit

    def on_message(self, kind: str, request_id: object) -> Credit | None:
        """The credit for a ``response.speak.start``/``end`` (None: nobody's)."""
        play = self._find(kind, request_id)
        if play is None:
            self.swallowed += 1
            return None
        if kind == "response.speak.end":
            self._by_id.pop(play.request_id, None)
        if play is not self.current or play.outcome is not None:
            self.swallowed += 1
            return None
        if kind == "response.speak.start":
            play.started = True
            return Credit("start", play.prompt_id, play_id=play.play_id)
        play.outcome = SKIPPED if not play.started else STOPPED if play.stopping else PLAYED
        return Credit("end", play.prompt_id, play.outcome, play.play_id)

    def stop(self) -> Credit | None:
        """The wizard stopped the prompt. One that never started ends now (``skipped``);
        one that speaks ends with the robot's end event (``stopped``)."""
        play = self.current
        if play is None or play.outcome is not None:
            return None
        play.stopping = True
        if play.started:
            return None
        play.outcome = SKIPPED
        return Credit("end", play.prompt_id, SKIPPED, play.play_id)

    def drop_all(self) -> Credit | None:
        """The connection is gone: nothing sent will be answered. The current play's end."""
        play, self.current = self.current, None
        self._by_id.clear()
        if play is None or play.outcome is not None:
            return None
        play.outcome = INTERRUPTED if play.started else SKIPPED
        return Credit("end", play.prompt_id, play.outcome, play.play_id)

    def _find(self, kind: str, request_id: object) -> Play | None:
        if isinstance(request_id, str) and request_id:
            return self._by_id.get(request_id)
        play = self.current
        if play is None or play.outcome is not None:
            return None
        if kind == "response.speak.start":
            return None if play.started else play
        return play if play.started else None
