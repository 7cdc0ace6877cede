"""Serving a hub subscription over a WebSocket until the client goes away.

Used by the phone and the wizard WebSockets: changes arrive in batches (everything queued
at that moment), incoming client messages are answered (``ping`` -> ``pong``), and a
client that disconnects ends the loop without leaving tasks behind.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
from collections.abc import Awaitable, Callable

from starlette.websockets import WebSocket, WebSocketDisconnect

from chameleons.backend.events import guard, jsontext
from chameleons.backend.events.hub import Message, Subscription

OnChange = Callable[[list[Message]], Awaitable[bool]]  # True: stop serving


async def send_json(websocket: WebSocket, message: Message) -> None:
    """Send one message; a client that does not read it in time is disconnected (guard)."""
    await guard.send_text(websocket, jsontext.dumps(message))


async def _answer_incoming(websocket: WebSocket) -> None:
    """Reply to pings (rate-limited, text only); return when the client disconnects."""
    inbound = guard.Inbound(websocket)
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            text = await inbound.text()
            try:
                message = json.loads(text)
            except (ValueError, RecursionError):  # not JSON, or nested past the parser
                continue
            if isinstance(message, dict) and message.get("type") == "ping":
                await send_json(websocket, {"type": "pong"})


async def serve(websocket: WebSocket, subscription: Subscription, on_change: OnChange) -> None:
    """Serve until the client goes; a guard's verdict closes the socket with its reason."""
    async with guard.guarded(websocket):
        await _serve(websocket, subscription, on_change)


async def _serve(websocket: WebSocket, subscription: Subscription, on_change: OnChange) -> None:
    receiver = asyncio.create_task(_answer_incoming(websocket))
    try:
        while True:
            getter = asyncio.create_task(subscription.get())
            done, _ = await asyncio.wait({receiver, getter}, return_when=asyncio.FIRST_COMPLETED)
            if receiver in done:
                getter.cancel()
                guard.raise_closed({receiver})
                return
            if await on_change([getter.result(), *subscription.drain()]):
                return
    except (WebSocketDisconnect, RuntimeError):
        return
    finally:
        receiver.cancel()
        with contextlib.suppress(asyncio.CancelledError, WebSocketDisconnect, RuntimeError):
            await receiver


def same_origin(websocket: WebSocket) -> bool:
    """Browsers send cookies with cross-site WebSocket handshakes: refuse other origins."""
    origin = websocket.headers.get("origin")
    if origin is None:
        return True  # not a browser (scripts, the rehearsal bot)
    host = websocket.headers.get("host", "")
    return origin.split("://", 1)[-1].rstrip("/") == host


def base_url(websocket: WebSocket) -> str:
    """The URL phones use: the configured public URL, else the one this socket came in on."""
    configured = websocket.app.state.settings.public_url
    if configured:
        return str(configured).rstrip("/")
    scheme = "https" if websocket.url.scheme == "wss" else "http"
    return f"{scheme}://{websocket.headers.get('host', 'localhost')}"
