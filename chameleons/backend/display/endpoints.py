"""``/ws/display/<booth>``: the robot display page's WebSocket (protocol: ``protocol.py``).

A page is let in with its booth token (``?token=``) or a staff session cookie from this
site. Outgoing messages come from the booth's :class:`DisplayChannel` subscription;
incoming speech events and telemetry go to ``channel.report``.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
from urllib.parse import urlsplit

from fastapi import APIRouter, WebSocket, WebSocketDisconnect
from starlette.concurrency import run_in_threadpool

from chameleons.backend.auth import repository
from chameleons.backend.auth.dependencies import SESSION_USER_KEY
from chameleons.backend.db import session_scope
from chameleons.backend.display.channel import DisplayChannel, Subscription, get_display_channel
from chameleons.backend.display.protocol import (
    ProtocolError,
    hello_message,
    parse_inbound,
    pong_message,
)
from chameleons.backend.display.tokens import (
    check_token,
    display_token,
    is_valid_booth,
    signing_key,
)

router = APIRouter(tags=["display"])

POLICY_VIOLATION = 1008


@router.websocket("/ws/display/{booth}")
async def display_socket(websocket: WebSocket, booth: str, token: str | None = None) -> None:
    if not is_valid_booth(booth) or not await _authorised(websocket, booth, token):
        await websocket.close(code=POLICY_VIOLATION)
        return
    await websocket.accept()
    channel = get_display_channel(websocket.app)
    with channel.subscribe(booth) as subscription:
        await websocket.send_text(json.dumps(hello_message(booth)))
        sender = asyncio.create_task(_send_loop(websocket, subscription))
        try:
            await _receive_loop(websocket, channel, subscription)
        finally:
            sender.cancel()
            with contextlib.suppress(asyncio.CancelledError, WebSocketDisconnect):
                await sender


async def _authorised(websocket: WebSocket, booth: str, token: str | None) -> bool:
    if token is not None:
        return check_token(display_token(signing_key(websocket.app), booth), token)
    staff_id = websocket.session.get(SESSION_USER_KEY)
    if not isinstance(staff_id, int) or not _same_origin(websocket):
        return False
    return await run_in_threadpool(_active_staff, websocket, staff_id)


def _same_origin(websocket: WebSocket) -> bool:
    # Cookies ride along on cross-site WebSocket handshakes: check where the page came from.
    origin = websocket.headers.get("origin")
    return origin is not None and urlsplit(origin).netloc == websocket.headers.get("host")


def _active_staff(websocket: WebSocket, staff_id: int) -> bool:
    with session_scope(websocket.app.state.sessionmaker) as db:
        user = repository.get_by_id(db, staff_id)
        return user is not None and user.is_active
    return False


async def _send_loop(websocket: WebSocket, subscription: Subscription) -> None:
    while True:
        message = await subscription.get()
        await websocket.send_text(json.dumps(message, separators=(",", ":")))


async def _receive_loop(
    websocket: WebSocket, channel: DisplayChannel, subscription: Subscription
) -> None:
    booth = subscription.booth
    while True:
        frame = await websocket.receive()
        if frame["type"] == "websocket.disconnect":
            return
        text = frame.get("text")
        if not isinstance(text, str):
            channel.counters["inbound.binary"] += 1
            continue
        try:
            message = parse_inbound(text)
        except ProtocolError as error:
            channel.counters[f"inbound.{error.reason}"] += 1
            continue
        if message["type"] == "ping":
            subscription.put(pong_message(message))
        else:
            await channel.report(booth, message)
