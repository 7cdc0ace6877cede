"""``DisplayChannel``: the in-process hub between the worker bridge and robot display pages.

Downstream, ``publish(booth, message)`` fans a protocol message (see
:mod:`chameleons.backend.display.protocol`) out to every page showing that booth; it may be
called from any thread (it hops onto the server's event loop). Upstream, pages'
speech events and telemetry arrive through ``report`` and go to the listeners (the bridge
forwards speech events to the worker).

The current face (with its renderer) and the last face frame of each booth are kept, so a page that
(re)connects shows the right character at once. A slow page loses old face/head frames,
never control messages; a page that does not read even those is disconnected.

A page that goes (closed, reloaded, the screen unplugged) while it plays a prompt never
reports the end: the worker would think the robot speaks on, and the console would tick a
prompt the participant did not hear to its end. When the booth's last page has been gone
for :data:`DISPLAY_GONE_GRACE_SECONDS` (a page that only lost its connection comes back
within it and reports the end itself), the channel reports that play's end for it, with
reason ``display_closed`` (:data:`DISPLAY_CLOSED`), and remembers the play as cut short
(:meth:`DisplayChannel.cut_short`).
"""

from __future__ import annotations

import asyncio
import contextlib
import inspect
import logging
import statistics
import threading
import time
from collections import Counter, deque
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from typing import Any

from fastapi import FastAPI

from chameleons.backend.display.protocol import DROPPABLE_TYPES, Message
from chameleons.backend.events.guard import POLICY_VIOLATION, SocketClosed, slow_client

log = logging.getLogger(__name__)

Listener = Callable[[str, Message], Awaitable[None] | None]
DEFAULT_QUEUE_LIMIT = 256
PRESENCE_STALE_SECONDS = 3.5  # the page reports once a second
PAINT_RATES_KEPT = 600  # ten minutes of the page's 1 Hz reports, longer than a booth check
DISPLAY_GONE_GRACE_SECONDS = 3.0  # the page's first reconnections come within it
DISPLAY_CLOSED = "display_closed"
CUT_PLAYS_KEPT = 64


class _Entry:
    __slots__ = ("alive", "message")

    def __init__(self, message: Message) -> None:
        self.message = message
        self.alive = True


class Subscription:
    """One connected page's outgoing queue. Only touched on the event loop's thread.

    Bounded, and O(1) (amortised) per message whatever the backlog: frames (face/head)
    are kept in a second queue of their own, so the oldest one is found without a scan and
    dropped in place (lazily: marked dead, skipped by ``get``). A queue full of control
    messages means the page is not reading: ``overflowed`` is set and ``get`` raises
    :class:`~chameleons.backend.events.guard.SocketClosed`, so the socket is closed.
    """

    def __init__(self, booth: str, limit: int, by_link: bool = False) -> None:
        self.booth = booth
        self.limit = limit
        self.by_link = by_link  # let in with the booth's link (not a staff login)
        self.dropped = 0
        self.overflowed = False
        self.revoked: str | None = None
        self._items: deque[_Entry] = deque()
        self._frames: deque[_Entry] = deque()  # the droppable entries of _items, in order
        self._live = 0
        self._ready = asyncio.Event()

    def put(self, message: Message) -> None:
        if self.overflowed:
            return
        droppable = message.get("type") in DROPPABLE_TYPES
        if self._live >= self.limit and not self._drop_oldest_frame():
            if droppable:
                self.dropped += 1
                return
            self.overflowed = True  # control messages are never dropped: shed the page
            self._ready.set()
            return
        entry = _Entry(message)
        self._items.append(entry)
        if droppable:
            self._frames.append(entry)
        self._live += 1
        if len(self._items) > 2 * self.limit:  # dead entries: compact, amortised O(1)
            self._items = deque(e for e in self._items if e.alive)
        self._ready.set()

    def _drop_oldest_frame(self) -> bool:
        while self._frames:
            entry = self._frames.popleft()
            if entry.alive:
                entry.alive = False
                self._live -= 1
                self.dropped += 1
                return True
        return False

    def revoke(self, reason: str) -> None:
        self.revoked = reason
        self._ready.set()

    async def get(self) -> Message:
        while True:
            if self.revoked is not None:
                raise SocketClosed(POLICY_VIOLATION, self.revoked)
            if self.overflowed:
                raise slow_client(f"{self.limit} messages queued")
            while self._items:
                entry = self._items.popleft()
                if entry.alive:
                    entry.alive = False
                    self._live -= 1
                    if self._frames and self._frames[0] is entry:
                        self._frames.popleft()
                    return entry.message
            self._ready.clear()
            await self._ready.wait()


class DisplayChannel:
    def __init__(self, queue_limit: int = DEFAULT_QUEUE_LIMIT) -> None:
        self.queue_limit = queue_limit
        self.counters: Counter[str] = Counter()
        self._lock = threading.Lock()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._subscriptions: dict[str, set[Subscription]] = {}
        self._faces: dict[str, Message] = {}  # the last set_face (face and renderer)
        self._last_frames: dict[str, Message] = {}
        self._telemetry: dict[str, Message] = {}
        self._telemetry_at: dict[str, float] = {}
        self._sound_blocked: dict[str, bool] = {}
        self._paint_rates: dict[str, deque[tuple[float, float]]] = {}  # (when, frames a second)
        self._listeners: list[Listener] = []
        # booth -> (prompt id, play id) the page said it started and has not ended
        self._playing: dict[str, tuple[str | None, str | None]] = {}
        self._cut: deque[tuple[str, str | None, str | None]] = deque(maxlen=CUT_PLAYS_KEPT)
        self._tasks: set[asyncio.Task[None]] = set()

    # -- downstream ---------------------------------------------------------------------
    def publish(self, booth: str, message: Message) -> None:
        """Send ``message`` to every page of ``booth`` (from any thread)."""
        loop = self._loop
        if loop is None or _running_in(loop):
            self._deliver(booth, message)
            return
        try:
            loop.call_soon_threadsafe(self._deliver, booth, message)
        except RuntimeError:  # the server's loop has stopped: nobody is listening
            self.counters["published_after_stop"] += 1

    def _deliver(self, booth: str, message: Message) -> None:
        kind = message.get("type")
        with self._lock:
            if kind == "set_face":
                self._faces[booth] = message
            elif kind == "face":
                self._last_frames[booth] = message
            subscriptions = list(self._subscriptions.get(booth, ()))
        self.counters[f"published.{kind}"] += 1
        for subscription in subscriptions:
            subscription.put(message)

    def revoke(self, booth: str, reason: str) -> None:
        """Disconnect the booth's pages that came in with its link (from any thread)."""
        loop = self._loop
        if loop is None or _running_in(loop):
            self._revoke(booth, reason)
            return
        with contextlib.suppress(RuntimeError):  # the loop has stopped: nobody is connected
            loop.call_soon_threadsafe(self._revoke, booth, reason)

    def _revoke(self, booth: str, reason: str) -> None:
        with self._lock:
            subscriptions = [s for s in self._subscriptions.get(booth, ()) if s.by_link]
        for subscription in subscriptions:
            subscription.revoke(reason)

    @contextmanager
    def subscribe(self, booth: str, by_link: bool = False) -> Iterator[Subscription]:
        """Register a page (call on the event loop); it first gets the booth's state."""
        self._loop = asyncio.get_running_loop()
        subscription = Subscription(booth, self.queue_limit, by_link)
        with self._lock:
            if booth in self._faces:
                subscription.put(self._faces[booth])
            if booth in self._last_frames:
                subscription.put(self._last_frames[booth])
            self._subscriptions.setdefault(booth, set()).add(subscription)
        try:
            yield subscription
        finally:
            with self._lock:
                self._subscriptions.get(booth, set()).discard(subscription)
                playing = self._playing.get(booth)
                last_gone = not self._subscriptions.get(booth)
            if last_gone and playing is not None:
                loop = asyncio.get_running_loop()
                loop.call_later(DISPLAY_GONE_GRACE_SECONDS, self._end_if_gone, booth, playing)

    def _end_if_gone(self, booth: str, play: tuple[str | None, str | None]) -> None:
        """The booth's pages stayed away while ``play`` played: report its end for them."""
        with self._lock:
            if self._subscriptions.get(booth) or self._playing.get(booth) != play:
                return
            del self._playing[booth]
            self._cut.append((booth, *play))
        prompt_id, play_id = play
        end = {"type": "speech", "event": "end", "prompt_id": prompt_id, "play_id": play_id,
               "reason": DISPLAY_CLOSED}  # fmt: skip
        self.counters["speech.display_closed"] += 1
        task = asyncio.get_running_loop().create_task(self.report(booth, end))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    def cut_short(self, booth: str, prompt_id: str | None, play_id: str | None) -> bool:
        """Whether this play ended because the booth's display went while it played."""
        with self._lock:
            cut = list(self._cut)
        if play_id is not None:
            return any(b == booth and played == play_id for b, _, played in cut)
        return any(b == booth and prompt == prompt_id for b, prompt, _ in cut)

    def connected(self, booth: str) -> int:
        with self._lock:
            return len(self._subscriptions.get(booth, ()))

    def current_face(self, booth: str) -> str | None:
        with self._lock:
            message = self._faces.get(booth)
        return None if message is None else str(message["face"])

    # -- upstream -----------------------------------------------------------------------
    def add_listener(self, listener: Listener, *, first: bool = False) -> None:
        """``listener(booth, message)`` gets every speech event and telemetry report;
        ``first``: before the listeners there are (e.g. before the one that forwards the
        report to the worker, whose answer may otherwise overtake it)."""
        if first:
            self._listeners.insert(0, listener)
        else:
            self._listeners.append(listener)

    def remove_listener(self, listener: Listener) -> None:
        self._listeners.remove(listener)

    async def report(self, booth: str, message: Message) -> None:
        if message.get("type") == "telemetry":
            now, fps = time.monotonic(), message.get("fps")
            with self._lock:
                self._telemetry[booth] = message
                self._telemetry_at[booth] = now
                if isinstance(fps, int | float) and not isinstance(fps, bool):
                    rates = self._paint_rates.setdefault(booth, deque(maxlen=PAINT_RATES_KEPT))
                    rates.append((now, float(fps)))
        elif message.get("type") == "speech":
            with self._lock:  # sound plays once the page had its click; say when it did not
                self._sound_blocked[booth] = message.get("reason") == "autoplay_blocked"
                self._follow_play(booth, message)
        self.counters[f"reported.{message.get('type')}"] += 1
        for listener in list(self._listeners):
            try:
                result: Any = listener(booth, message)
                if inspect.isawaitable(result):
                    await result
            except Exception:  # a listener's bug must not cut the display off
                log.exception("display listener failed for booth %s", booth)

    def _follow_play(self, booth: str, message: Message) -> None:
        """Which play the booth's page is speaking (call with the lock held)."""
        prompt_id, play_id = message.get("prompt_id"), message.get("play_id")
        play = (prompt_id if isinstance(prompt_id, str) else None,
                play_id if isinstance(play_id, str) else None)  # fmt: skip
        if message.get("event") == "start":
            self._playing[booth] = play
        elif message.get("event") == "end" and self._playing.get(booth) == play:
            del self._playing[booth]

    def presence(self, booth: str) -> tuple[bool, str]:
        """Whether a display page of ``booth`` is open and playing (the virtual robot is
        "connected"), and if not, why: no page, a page that stopped reporting (a closed lid,
        a background tab), or one that needs a click before it plays sound."""
        with self._lock:
            pages = len(self._subscriptions.get(booth, ()))
            age = time.monotonic() - self._telemetry_at.get(booth, -1e18)
            fps = (self._telemetry.get(booth) or {}).get("fps")
            blocked = self._sound_blocked.get(booth, False)
        if pages == 0:
            return False, "no robot display open"
        if age > PRESENCE_STALE_SECONDS or (isinstance(fps, int | float) and fps <= 0):
            return False, "robot display not playing"
        if blocked:
            return False, "robot display needs a click to enable sound"
        return True, "display open"

    def paint_rate(self, booth: str, since: float) -> float | None:
        """The median of the frames a second the booth's display pages reported since
        ``since`` (``time.monotonic()``), None without a report. What a participant saw
        over that time, which ``presence`` cannot say: a page in a background tab or a
        covered window paints a frame or two a second, enough to count as playing in most
        of its 1 s reports."""
        # A report covers the second before it, so the one from the second before
        # ``since`` counts too: a check shorter than a second still has one.
        with self._lock:
            rates = [fps for at, fps in self._paint_rates.get(booth, ()) if at >= since - 1.0]
        return statistics.median(rates) if rates else None

    def telemetry(self, booth: str) -> Message | None:
        """The latest telemetry report of the booth's display page, if any."""
        with self._lock:
            return self._telemetry.get(booth)


def _running_in(loop: asyncio.AbstractEventLoop) -> bool:
    try:
        return asyncio.get_running_loop() is loop
    except RuntimeError:
        return False


_CREATE_LOCK = threading.Lock()


def get_display_channel(app: FastAPI) -> DisplayChannel:
    """The app's channel, created on first use (``app.state.display_channel``)."""
    with _CREATE_LOCK:
        channel = getattr(app.state, "display_channel", None)
        if channel is None:
            channel = DisplayChannel()
            app.state.display_channel = channel
    assert isinstance(channel, DisplayChannel)
    return channel
