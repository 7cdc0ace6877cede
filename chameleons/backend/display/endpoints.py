"""``/ws/display/<booth>``: the robot display page's WebSocket (protocol: ``protocol.py``).

A page is let in with its booth token (``?token=``) or a staff session cookie from this
site. Outgoing messages come from the booth's :class:`DisplayChannel` subscription;
incoming speech events and telemetry go to ``channel.report``.
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any
from urllib.parse import urlsplit

from fastapi import WebSocket, WebSocketDisconnect
from starlette.concurrency import run_in_threadpool

from chameleons.backend.auth import sessions as staff_sessions
from chameleons.backend.auth.socket_revocation import serve_while_signed_in
from chameleons.backend.db import session_scope
from chameleons.backend.display import links
from chameleons.backend.display.channel import DisplayChannel, Subscription, get_display_channel
from chameleons.backend.display.protocol import (
    ProtocolError,
    hello_message,
    parse_inbound,
    pong_message,
)
from chameleons.backend.display.tokens import is_valid_booth
from chameleons.backend.events import guard, jsontext
from chameleons.backend.routing import make_router

router = make_router(tags=["display"])

POLICY_VIOLATION = 1008


@router.websocket("/ws/display/{booth}")
async def display_socket(websocket: WebSocket, booth: str, token: str | None = None) -> None:
    allowed, staff_session = False, None
    if is_valid_booth(booth):
        allowed, staff_session = await _authorised(websocket, booth, token)
    if not allowed:
        await websocket.close(code=POLICY_VIOLATION)
        return
    await websocket.accept()
    # A page let in by a staff cookie closes (4401) when that login ends; by link, it stays.
    await serve_while_signed_in(websocket, staff_session, lambda: _serve(websocket, booth, token))


async def _serve(websocket: WebSocket, booth: str, token: str | None) -> None:
    channel = get_display_channel(websocket.app)
    async with guard.guarded(websocket):
        with channel.subscribe(booth, by_link=token is not None) as subscription:
            await guard.send_text(websocket, jsontext.dumps(hello_message(booth)))
            sender = asyncio.create_task(_send_loop(websocket, subscription))
            receiver = asyncio.create_task(_receive_loop(websocket, channel, subscription))
            tasks = {sender, receiver}
            try:
                await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
                guard.raise_closed(tasks)
            finally:
                for task in tasks:
                    task.cancel()
                for task in tasks:
                    with contextlib.suppress(asyncio.CancelledError, Exception):
                        await task


async def _authorised(
    websocket: WebSocket, booth: str, token: str | None
) -> tuple[bool, int | None]:
    """Whether the page may connect, and the staff session it came in on (None by link)."""
    if token is not None:
        return await run_in_threadpool(_token_works, websocket, booth, token), None
    if not _same_origin(websocket):
        return False, None
    staff_session = await run_in_threadpool(_staff_session, websocket, dict(websocket.session))
    return staff_session is not None, staff_session


def _same_origin(websocket: WebSocket) -> bool:
    # Cookies ride along on cross-site WebSocket handshakes: check where the page came from.
    origin = websocket.headers.get("origin")
    return origin is not None and urlsplit(origin).netloc == websocket.headers.get("host")


def _token_works(websocket: WebSocket, booth: str, token: str) -> bool:
    with session_scope(websocket.app.state.sessionmaker) as db:
        return links.token_works(db, websocket.app, booth, token)


def _staff_session(websocket: WebSocket, cookie: dict[str, Any]) -> int | None:
    with session_scope(websocket.app.state.sessionmaker) as db:
        found = staff_sessions.signed_in(db, cookie)
        return found[1] if found is not None else None


async def _send_loop(websocket: WebSocket, subscription: Subscription) -> None:
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            message = await subscription.get()
            await guard.send_text(websocket, jsontext.dumps(message))


async def _receive_loop(
    websocket: WebSocket, channel: DisplayChannel, subscription: Subscription
) -> None:
    booth = subscription.booth
    inbound = guard.Inbound(websocket)
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            text = await inbound.text()
            try:
                message = parse_inbound(text)
            except ProtocolError as error:
                channel.counters[f"inbound.{error.reason}"] += 1
                continue
            if message["type"] == "ping":
                subscription.put(pong_message(message))
            else:
                await channel.report(booth, message)
