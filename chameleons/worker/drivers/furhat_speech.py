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
  ``interrupted`` (``stopped`` when the wizard had stopped it): neither is ever reported as
  played, and the robot's late events for it are swallowed so they cannot end the new
  prompt. The tracker ends every play exactly once, a replaced one when it is replaced
  (also when its start reached the tracker but not yet the renderer, which then never
  heard of it speaking; the renderer drops an end it has already given);
- ``response.speak.end`` says how the speech ended (Furhat's documented fields ``aborted``
  and ``failed``; docs/furhat.md): ``failed: true`` is ``failed`` (the robot could not
  play it, e.g. an audio URL it cannot reach), never ``played``; ``aborted: true`` on a
  play nobody here stopped is ``interrupted``. A failed end without a ``request_id`` is
  the current play's even before its start (an aborted earlier play ends ``aborted``, not
  ``failed``).
"""

from __future__ import annotations

import contextlib
import ipaddress
import uuid
from dataclasses import dataclass
from urllib.parse import urlsplit

PLAYED, INTERRUPTED, SKIPPED, STOPPED = "played", "interrupted", "skipped", "stopped"
FAILED = "failed"  # the robot could not speak it (``response.speak.end`` ``failed: true``)


@dataclass
class Play:
    prompt_id: str
    request_id: str
    play_id: str | None = None  # the server's id of this play (its events carry it)
    what: str = ""  # what the robot was asked to say: the audio URL ("" for typed text)
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
    what: str = ""  # the play's audio URL ("" for typed text), for a failure's reason
    detail: str | None = None  # the robot's own words on a failure, if it gave any


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

    def begin(
        self, prompt_id: str, play_id: str | None = None, what: str = ""
    ) -> tuple[Play, Credit | None]:
        """A new play; the end of the play it replaces, if one was under way: ``skipped``
        (never started), ``stopped`` (the wizard stopped it) or ``interrupted``. Given also
        when the renderer ended it already (it drops the second): its start may have
        reached this tracker but not yet the renderer, which then ends nothing."""
        credit = None
        old = self.current
        if old is not None and old.outcome is None:
            old.outcome = (SKIPPED if not old.started else STOPPED if old.stopping
                           else INTERRUPTED)  # fmt: skip
            self.replaced = [*self.replaced[-15:], old]
            credit = Credit("end", old.prompt_id, old.outcome, old.play_id)
        play = Play(prompt_id, uuid.uuid4().hex, play_id, what)
        self.current = play
        self._by_id[play.request_id] = play
        return play, credit

    def on_message(
        self, kind: str, request_id: object, *, failed: bool = False, aborted: bool = False,
        detail: str | None = None,
    ) -> Credit | None:  # fmt: skip
        """The credit for a ``response.speak.start``/``end`` (None: nobody's); ``failed``
        and ``aborted`` are the end's fields, ``detail`` the robot's words on a failure."""
        play = self._find(kind, request_id, failed)
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
        if failed:
            play.outcome = FAILED
            return Credit("end", play.prompt_id, FAILED, play.play_id, play.what, detail)
        play.outcome = (SKIPPED if not play.started else STOPPED if play.stopping
                        else INTERRUPTED if aborted else PLAYED)  # fmt: skip
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

    def _find(self, kind: str, request_id: object, failed: bool = False) -> Play | None:
        if isinstance(request_id, str) and request_id:
            return self._by_id.get(request_id)
        play = self.current
        if play is None or play.outcome is not None:
            return None
        if kind == "response.speak.start":
            return None if play.started else play
        return play if play.started or failed else None


def failure_reason(credit: Credit, voice: str | None = None) -> str:
    """Why the robot did not say a failed play, in the words the wizard and the booth check
    show: the URL it could not play, with a hint when that URL names a loopback address
    (the server's ``CHAMELEONS_PUBLIC_URL`` left unset: only a robot on the server's own
    computer, e.g. Furhat's SDK, reaches it)."""
    said = f" ({credit.detail})" if credit.detail else ""
    if not credit.what:
        in_voice = f" in the voice {voice}" if voice else ""
        return f"the robot could not say the typed text{in_voice}{said}"
    reason = f"the robot could not play the audio at {credit.what}{said}"
    host = _host(credit.what)
    if host is not None and loopback(host):
        reason += (f"; {host} is the server's own loopback address, which a robot on another "
                   "computer cannot reach: set CHAMELEONS_PUBLIC_URL to the server's address "
                   "on the robot's network")  # fmt: skip
    return reason


def _host(url: str) -> str | None:
    with contextlib.suppress(ValueError):
        return urlsplit(url).hostname
    return None


def loopback(host: str) -> bool:
    """An address only this computer reaches (``localhost``, 127.x, ::1, 0.0.0.0)."""
    name = host.lower()
    if name == "localhost" or name.endswith(".localhost"):
        return True
    try:
        address = ipaddress.ip_address(name)
    except ValueError:
        return False
    return address.is_loopback or address.is_unspecified
