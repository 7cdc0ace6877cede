"""Async subscriber queues of the bridge: bounded, the oldest display frame dropped first."""

from __future__ import annotations

import asyncio
from collections import deque
from collections.abc import Callable

from chameleons.worker.envelope import Message

DISPLAY_FRAMES = frozenset({"face", "head"})  # stale the moment a newer one exists


class Subscription:
    """Messages of some kinds (``telemetry``, ``event``, ``display``, ``worker``) for one
    booth or all. Iterate with ``async for``; ``close()`` (or ``with``) when done.

    When full, the oldest display frame is dropped to make room; if there is none, the
    oldest message. Drops are counted in ``dropped``.
    """

    def __init__(self, booth: str | None, kinds: tuple[str, ...], limit: int,
                 on_close: Callable[[Subscription], None]) -> None:  # fmt: skip
        self.booth, self.kinds, self.limit = booth, frozenset(kinds), max(1, limit)
        self.dropped = 0
        self.closed = False
        self._items: deque[Message] = deque()
        self._ready = asyncio.Event()
        self._on_close = on_close

    def offer(self, message: Message, booth: str) -> None:
        kind = message.topic.partition(".")[0]
        if self.closed or kind not in self.kinds or (self.booth and booth != self.booth):
            return
        if len(self._items) >= self.limit:
            self._drop_one()
        self._items.append(message)
        self._ready.set()

    def _drop_one(self) -> None:
        self.dropped += 1
        for i, queued in enumerate(self._items):
            if queued.topic.startswith("display.") and queued.type in DISPLAY_FRAMES:
                del self._items[i]
                return
        self._items.popleft()

    async def get(self) -> Message:
        while not self._items:
            if self.closed:
                raise StopAsyncIteration
            self._ready.clear()
            await self._ready.wait()
        return self._items.popleft()

    def get_nowait(self) -> Message | None:
        return self._items.popleft() if self._items else None

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._ready.set()
            self._on_close(self)

    def __aiter__(self) -> Subscription:
        return self

    async def __anext__(self) -> Message:
        return await self.get()

    def __enter__(self) -> Subscription:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()
