"""The console's WebSocket ``/ws/wizard/sessions/{id}`` (staff login via the cookie).

On connect ``{"type": "console", ...}`` (the whole console state); then, per batch of
committed changes, each new event as ``{"type": "event", ...}`` followed by a fresh console
state whose timeline holds only that batch's events (``events_delta``; the whole timeline
again after a ``resync``); and the robot's health as ``{"type": "health", ...}`` on connect
and then only when it changed (looked at once a second, the rate a person reads the strip:
a failing check's ``failing_for`` and the heartbeat's ``speaking_age_s`` grow with the clock
alone and do not count as a change; the console adds the time since the message). When
the session is deleted (its participant withdrawn), ``{"type": "gone"}`` and the socket
closes.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
from datetime import UTC, datetime
from typing import Any

import anyio
from fastapi import WebSocket, WebSocketDisconnect
from starlette.concurrency import run_in_threadpool

from chameleons.backend.auth import sessions as staff_sessions
from chameleons.backend.auth.socket_revocation import serve_while_signed_in
from chameleons.backend.events import guard, live
from chameleons.backend.events.hub import RESYNC, LiveHub, Message, session_channel
from chameleons.backend.events.repository import GONE
from chameleons.backend.routing import make_router
from chameleons.backend.studies.errors import NotFoundError
from chameleons.backend.wizard import health, robot, typed_speech, worker_link
from chameleons.backend.wizard.console_state import committed_console_state, console_state
from chameleons.backend.wizard.playback import read
from chameleons.backend.wizard.video_health import filming, study_records_video, video_check

router = make_router(tags=["wizard"])
HEALTH_INTERVAL_SECONDS = 1.0  # how often the health is looked at (sent only when changed)
UNAUTHORIZED = 4401
NOT_FOUND = 4404


class Sender:
    """Two tasks write to one socket; a lock keeps whole messages apart."""

    def __init__(self, websocket: WebSocket) -> None:
        self._websocket = websocket
        self._lock = asyncio.Lock()

    async def send(self, message: Message) -> None:
        async with self._lock:
            await live.send_json(self._websocket, message)


def _staff_session(db: Any, cookie: dict[str, Any]) -> int | None:
    found = staff_sessions.signed_in(db, cookie)
    return found[1] if found is not None else None


def _state_message(
    db: Any, state: Any, session_id: int, base_url: str, new_events: list[Message] | None = None
) -> Message:
    return {"type": "console", **console_state(db, state, session_id, base_url, new_events)}


def _new_events(messages: list[Message]) -> list[Message] | None:
    """The events of a batch, or None when the subscription fell behind (a ``resync``: the
    batch is not the whole story, so the console gets its whole timeline again)."""
    if any(message.get("type") == RESYNC["type"] for message in messages):
        return None
    return [message["event"] for message in messages if message.get("type") == "event"]


@router.websocket("/ws/wizard/sessions/{session_id}")
async def console_feed(websocket: WebSocket, session_id: int) -> None:
    state = websocket.app.state
    cookie = dict(websocket.session)
    staff_session = None
    if live.same_origin(websocket):
        staff_session = await run_in_threadpool(read, state, _staff_session, cookie)
    if staff_session is None:
        await websocket.close(code=UNAUTHORIZED)
        return
    # Closed with 4401 when this login ends (logout, deactivation): not only at the handshake.
    await serve_while_signed_in(websocket, staff_session, lambda: _serve(websocket, session_id))


async def _serve(websocket: WebSocket, session_id: int) -> None:
    state = websocket.app.state
    base_url = live.base_url(websocket)
    hub: LiveHub = state.live_hub
    # Subscribed before the first read: a change committed meanwhile reaches this console
    # as a message (its event is then in both; the console keeps one of each id).
    async with hub.subscribe(session_channel(session_id)) as subscription:
        try:
            first = await run_in_threadpool(
                read, state, _state_message, state, session_id, base_url
            )
        except NotFoundError:
            # Accepted first so the console learns why (a refused handshake looks like a
            # network failure and it would retry for ever); staff only, checked above.
            await websocket.accept()
            await live.send_json(websocket, GONE)
            await websocket.close(code=NOT_FOUND)
            return
        await websocket.accept()
        sender = Sender(websocket)
        booth = str(first["session"]["booth"])
        study_id = first["session"].get("study_id")
        # Which robots the study's conditions run on (a booth with both robots says when
        # the one a later condition needs is missing).
        needs = await run_in_threadpool(read, state, robot.robots_needed, study_id)
        # A study that films its participants: the health looks at the session's filming.
        filmed = await run_in_threadpool(read, state, study_records_video, study_id)
        await sender.send(first)

        reads: set[asyncio.Future[Message]] = set()

        async def forward_changes() -> Message:
            while True:
                messages = [await subscription.get(), *subscription.drain()]
                for message in messages:
                    if message.get("type") != "resync":
                        await sender.send(message)
                if any(message.get("type") == GONE["type"] for message in messages):
                    return GONE  # withdrawn: the tab says so and stops reconnecting
                # Shielded: a read cut off by a disconnect still finishes (and gives its
                # database connection back) before the handler returns.
                new_events = _new_events(messages)
                # The state the change committed, kept by the hub: built here at once.
                known = committed_console_state(state, session_id, base_url, new_events or [])
                if known is not None:
                    await sender.send({"type": "console", **known})
                    continue
                reading = asyncio.ensure_future(
                    run_in_threadpool(
                        read, state, _state_message, state, session_id, base_url, new_events
                    )
                )
                reads.add(reading)
                reading.add_done_callback(reads.discard)
                try:
                    fresh = await asyncio.shield(reading)
                except NotFoundError:  # deleted between the change and this read
                    await sender.send(GONE)
                    return GONE
                await sender.send(fresh)

        tasks = [
            asyncio.create_task(forward_changes()),
            asyncio.create_task(_forward_health(sender, state, booth, needs,
                                                session_id if filmed else None)),
            asyncio.create_task(_answer_pings(websocket, sender)),
        ]
        try:
            async with guard.guarded(websocket):
                done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
                guard.raise_closed(done)
        finally:
            for task in tasks:
                task.cancel()
            for task in tasks:
                with contextlib.suppress(
                    asyncio.CancelledError, WebSocketDisconnect, RuntimeError, guard.SocketClosed
                ):
                    await task
            with anyio.CancelScope(shield=True):  # even when the server cancels the handler
                await asyncio.gather(*reads, return_exceptions=True)
        forward = tasks[0]  # its SocketClosed (a slow client) was handled by guarded above
        ended = forward.done() and not forward.cancelled() and forward.exception() is None
        if ended and forward.result() is GONE:
            with contextlib.suppress(WebSocketDisconnect, RuntimeError):
                await websocket.close(code=NOT_FOUND)


async def _answer_pings(websocket: WebSocket, sender: Sender) -> None:
    """Reply to the console's pings (it measures the link); return when it disconnects."""
    inbound = guard.Inbound(websocket)
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            try:
                message = json.loads(await inbound.text())
            except (ValueError, RecursionError):  # not JSON, or nested past the parser
                continue
            if isinstance(message, dict) and message.get("type") == "ping":
                await sender.send({"type": "pong"})


def display_presence(state: Any, booth: str) -> tuple[bool, str] | None:
    channel = getattr(state, "display_channel", None)
    presence = getattr(channel, "presence", None)
    return presence(booth) if callable(presence) else (False, "no robot display open")


def display_paint_rate(state: Any, booth: str, since: float) -> float | None:
    """The booth's display's median frames a second since ``since`` (``time.monotonic()``;
    :meth:`DisplayChannel.paint_rate`), None without a display or a report."""
    channel = getattr(state, "display_channel", None)
    paint_rate = getattr(channel, "paint_rate", None)
    return paint_rate(booth, since) if callable(paint_rate) else None


def health_content(snapshot: Message) -> Message:
    """What a health message says apart from the clock: the snapshot without the durations
    that grow by themselves (``failing_for`` and ``since_s`` of each check,
    ``speaking_age_s``), which the console extrapolates from the message's arrival."""
    checks = [{k: v for k, v in check.items() if k not in ("failing_for", "since_s")}
              for check in snapshot.get("checks", [])]  # fmt: skip
    return {**{k: v for k, v in snapshot.items() if k != "speaking_age_s"}, "checks": checks}


async def _forward_health(
    sender: Sender, state: Any, booth: str, needs: health.Needs | None = None,
    filmed_session: int | None = None,
) -> None:
    """The booth's health now, then whenever it changes (looked at once a second): an
    unchanged health sends nothing (it was a push to every console every second, about 12 %
    of a busy server's CPU, issue 34). ``filmed_session``: a session of a study that films
    its participants, whose filming is read at each look for the video chip (two small
    reads by key; a study that films nobody reads nothing)."""
    tracker = health.tracker_of(state)
    last: Message | None = None
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            bridge = worker_link.bridge_of(state)
            telemetry, age = worker_link.latest_telemetry(bridge, booth)
            display = display_presence(state, booth)
            found = typed_speech.synthesiser_of(state)
            synthesiser = (found.available, found.detail) if found is not None else None
            extra = None
            if filmed_session is not None:
                now_filming = await run_in_threadpool(read, state, filming, filmed_session)
                extra = video_check(now_filming, datetime.now(UTC))
            snapshot = tracker.snapshot(booth, telemetry, age, display=display,
                                        synthesiser=synthesiser, needs=needs,
                                        extra=extra)  # fmt: skip
            snapshot["bridge"] = bridge is not None
            content = health_content(snapshot)
            if content != last:
                await sender.send(snapshot)
                last = content
            await asyncio.sleep(HEALTH_INTERVAL_SECONDS)
