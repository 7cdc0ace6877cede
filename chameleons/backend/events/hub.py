"""An in-process publish/subscribe hub for live updates (phone and wizard WebSockets).

Publishing never blocks: it may be called from the event loop or from a worker thread (sync
endpoints run in a thread pool), and it hands the message to the loop with
``call_soon_threadsafe``. Each subscriber has a bounded queue; a subscriber that falls
behind loses its backlog and receives one ``{"type": "resync"}`` instead, so it re-reads the
state from the database rather than slowing the publisher down.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
import time
from collections import Counter, OrderedDict, defaultdict
from collections.abc import AsyncIterator, Callable, Iterator
from typing import Any, Protocol

log = logging.getLogger(__name__)
Message = dict[str, Any]
Listener = Callable[[str, Message], None]
RESYNC: Message = {"type": "resync"}
RETAINED_CHANNELS = 1024


# Message types from another process after which the views kept for the channel are stale
# (events.repository's resync after a rewrite, and gone after a withdrawal).
PEER_FORGETS = frozenset({"resync", "gone"})


def _version(views: dict[str, Message]) -> int:
    """The newest version among a commit's views (each view's ``version``: the session's
    newest event id when it was made)."""
    return max((int(view.get("version") or 0) for view in views.values()), default=0)


def session_channel(session_id: int) -> str:
    return f"session:{session_id}"


class Subscription:
    """One listener's queue. ``get`` waits for the next message."""

    def __init__(self, channel: str, size: int) -> None:
        self.channel = channel
        self._queue: asyncio.Queue[Message] = asyncio.Queue(maxsize=size)

    def offer(self, message: Message) -> None:
        if self._queue.full():
            # Drop the backlog rather than block the publisher; the listener re-reads state.
            while not self._queue.empty():
                self._queue.get_nowait()
            self._queue.put_nowait(RESYNC)
            return
        self._queue.put_nowait(message)

    async def get(self) -> Message:
        return await self._queue.get()

    def drain(self) -> list[Message]:
        """Messages already waiting, without waiting for more."""
        pending: list[Message] = []
        while not self._queue.empty():
            pending.append(self._queue.get_nowait())
        return pending


class Relay(Protocol):
    """Carries this process's messages to other server processes (events.pg_fanout)."""

    def send(self, channel: str, message: Message) -> None: ...

    def send_retained(self, channel: str, views: dict[str, Message]) -> None: ...

    def send_presence(self) -> None: ...


class LiveHub:
    def __init__(self, queue_size: int = 256) -> None:
        self._queue_size = queue_size
        self._loop: asyncio.AbstractEventLoop | None = None
        self._subscribers: dict[str, set[Subscription]] = defaultdict(set)
        self._present: Counter[str] = Counter()
        self._details: dict[str, dict[int, Message]] = defaultdict(dict)
        self._listeners: list[Listener] = []
        self._relay: Relay | None = None
        # Other processes' presence maps, each counted until its expiry (monotonic time).
        self._peers: dict[str, tuple[dict[str, int], float]] = {}
        self._peer_details: dict[str, dict[str, list[Message]]] = {}
        self._retained: OrderedDict[str, dict[str, Message]] = OrderedDict()
        self._retained_lock = threading.Lock()

    def attach_relay(self, relay: Relay | None) -> None:
        """Also send every message published here through ``relay`` (from the loop)."""
        self._loop = asyncio.get_running_loop()
        self._relay = relay

    def add_listener(self, listener: Listener) -> Callable[[], None]:
        """Call ``listener(channel, message)`` for every message published on any channel,
        on the hub's event loop (server-side reactions to committed events, e.g. the booth
        flow). It must return at once (queue the work); its exceptions are logged. Call this
        from the running loop; returns a function that removes the listener."""
        self._loop = asyncio.get_running_loop()
        self._listeners.append(listener)

        def remove() -> None:
            if listener in self._listeners:
                self._listeners.remove(listener)

        return remove

    def publish(self, channel: str, message: Message) -> None:
        """Deliver ``message`` to the channel's subscribers; safe from any thread."""
        self._on_loop(self._publish_here, channel, message)

    def publish_all(self, messages: list[tuple[str, Message]]) -> None:
        """``publish`` each ``(channel, message)`` in one turn of the loop: a subscriber woken
        by the first finds the others queued (a commit's events reach a console as one
        batch, whose newest event is the one its retained state is of)."""
        if messages:
            self._on_loop(self._publish_each, "", messages)

    def _publish_each(self, _channel: str, messages: list[tuple[str, Message]]) -> None:
        for channel, message in messages:
            self._publish_here(channel, message)

    def _on_loop(self, call: Callable[[str, Any], None], channel: str, value: Any) -> None:
        """``call(channel, value)`` on the hub's loop: at once when called there, else in
        the order of calls from any thread (a commit's retained views before its events)."""
        loop = self._loop
        if loop is None or loop.is_closed():
            return  # nobody has ever subscribed in a running loop
        try:
            running: asyncio.AbstractEventLoop | None = asyncio.get_running_loop()
        except RuntimeError:
            running = None
        if running is loop:
            call(channel, value)
            return
        with contextlib.suppress(RuntimeError):  # the loop closed meanwhile: nobody listens
            loop.call_soon_threadsafe(call, channel, value)

    def deliver(self, channel: str, message: Message) -> None:
        """A message another process published (on the loop): to subscribers and listeners.
        A resync or gone also drops the views kept from that process: what they showed has
        been rewritten or deleted."""
        if message.get("type") in PEER_FORGETS:
            self.forget(channel)
        self._deliver(channel, message)

    def _publish_here(self, channel: str, message: Message) -> None:
        self._deliver(channel, message)
        if self._relay is not None:
            self._relay.send(channel, message)

    def retain(self, channel: str, views: dict[str, Message]) -> None:
        """Keep ``views`` (one value per reader: the console's, the phone's) as the channel's
        latest committed state (as MQTT's retained message), and send them to the other
        server processes through the relay, before the events of the same commit. Safe from
        any thread; the least recently retained channels are forgotten beyond
        ``RETAINED_CHANNELS``."""
        self._keep(channel, views)
        if self._relay is not None:
            self._on_loop(self._relay_retained, channel, views)

    def retain_from_peer(self, channel: str, views: dict[str, Message]) -> None:
        """Views another process retained (on the loop): kept unless this process keeps
        views of a newer version already (a change here committed after that one)."""
        with self._retained_lock:
            kept = self._retained.get(channel)
            if kept is not None and _version(kept) > _version(views):
                return
        self._keep(channel, views)

    def _keep(self, channel: str, views: dict[str, Message]) -> None:
        with self._retained_lock:
            self._retained[channel] = views
            self._retained.move_to_end(channel)
            while len(self._retained) > RETAINED_CHANNELS:
                self._retained.popitem(last=False)

    def _relay_retained(self, channel: str, views: dict[str, Message]) -> None:
        if self._relay is not None:
            self._relay.send_retained(channel, views)

    def retained(self, channel: str, view: str) -> Message | None:
        """The value of ``view`` last retained on ``channel`` (shared: readers must not
        change it), None when the latest retained state has no such view."""
        with self._retained_lock:
            return self._retained.get(channel, {}).get(view)

    def forget(self, channel: str) -> None:
        with self._retained_lock:
            self._retained.pop(channel, None)

    def subscriber_count(self, channel: str) -> int:
        return len(self._subscribers.get(channel, ()))

    @contextlib.asynccontextmanager
    async def subscribe(self, channel: str) -> AsyncIterator[Subscription]:
        self._loop = asyncio.get_running_loop()
        subscription = Subscription(channel, self._queue_size)
        self._subscribers[channel].add(subscription)
        try:
            yield subscription
        finally:
            listeners = self._subscribers.get(channel)
            if listeners is not None:
                listeners.discard(subscription)
                if not listeners:
                    del self._subscribers[channel]

    @contextlib.contextmanager
    def presence(self, key: str, detail: Message | None = None) -> Iterator[None]:
        """Count a connection (e.g. the participant's phone) while it lasts; ``detail``
        (e.g. which phone, since when) is listed by ``present_details`` meanwhile."""
        self._present[key] += 1
        handle = id(detail)
        if detail is not None:
            self._details[key][handle] = detail
        self._presence_changed()
        try:
            yield
        finally:
            self._present[key] -= 1
            if self._present[key] <= 0:
                del self._present[key]
            details = self._details.get(key)
            if details is not None:
                details.pop(handle, None)
                if not details:
                    del self._details[key]
            self._presence_changed()

    def present(self, key: str) -> int:
        """Connections counted here and, within their expiry, in other processes."""
        now = time.monotonic()
        remote = sum(m.get(key, 0) for m, expiry in self._peers.values() if expiry > now)
        return self._present.get(key, 0) + remote

    def local_presence(self) -> dict[str, int]:
        return dict(self._present)

    def local_details(self) -> dict[str, list[Message]]:
        return {key: list(details.values()) for key, details in self._details.items()}

    def peer_presence(
        self,
        origin: str,
        present: dict[str, int],
        expiry: float,
        details: dict[str, list[Message]] | None = None,
    ) -> None:
        self._peers[origin] = (present, expiry)
        self._peer_details[origin] = details or {}

    def _presence_changed(self) -> None:
        if self._relay is not None:
            self._relay.send_presence()

    def present_details(self, key: str) -> list[Message]:
        """The details of the connections present under ``key`` here and (within their
        expiry) in other processes, oldest first by their ``connected_at``."""
        now = time.monotonic()
        remote = [
            detail
            for origin, (_, expiry) in self._peers.items()
            if expiry > now
            for detail in self._peer_details.get(origin, {}).get(key, [])
        ]
        here = list(self._details.get(key, {}).values())
        return sorted([*here, *remote], key=lambda d: str(d.get("connected_at", "")))

    def _deliver(self, channel: str, message: Message) -> None:
        for subscription in list(self._subscribers.get(channel, ())):
            subscription.offer(message)
        for listener in list(self._listeners):
            try:
                listener(channel, message)
            except Exception:  # a listener's bug must not stop live updates
                log.exception("live hub listener failed on %s", channel)
