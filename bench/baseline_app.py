"""The server benchmark's baseline: the least a FastAPI server can do for the same traffic.

``POST /api/submit/{channel}`` answers at once and pushes ``{"client_id": ...}`` to every
WebSocket on ``/ws/{channel}``: the shape of a phone's submission reaching the wizard's
console, with no database, no session logic and no console state. The WebSocket ``/echo``
returns each text message at once (the bare round trip of ``bench.speech_bench``). Run by
the benchmarks as its own uvicorn process, exactly as the real server is.
"""

from __future__ import annotations

import asyncio
from collections import defaultdict

from fastapi import FastAPI, WebSocket, WebSocketDisconnect
from pydantic import BaseModel

app = FastAPI()
_listeners: defaultdict[str, set[asyncio.Queue[str]]] = defaultdict(set)


class Submission(BaseModel):
    client_id: str


@app.post("/api/submit/{channel}")
async def submit(channel: str, body: Submission) -> dict[str, bool]:
    for queue in _listeners[channel]:
        queue.put_nowait(body.client_id)
    return {"ok": True}


@app.get("/healthz")
async def healthz() -> dict[str, str]:
    return {"status": "ok"}


@app.websocket("/ws/{channel}")
async def listen(websocket: WebSocket, channel: str) -> None:
    """Pushes the channel's submissions; reads (and ignores) what the client sends, which
    is how it learns at once that the client left (the real server does the same)."""
    await websocket.accept()
    queue: asyncio.Queue[str] = asyncio.Queue()
    _listeners[channel].add(queue)

    async def push() -> None:
        while True:
            await websocket.send_json({"type": "event", "client_id": await queue.get()})

    pushing = asyncio.create_task(push())
    try:
        while True:
            await websocket.receive_text()
    except WebSocketDisconnect:
        pass
    finally:
        pushing.cancel()
        _listeners[channel].discard(queue)


@app.websocket("/echo")
async def echo(websocket: WebSocket) -> None:
    await websocket.accept()
    try:
        while True:
            await websocket.send_text(await websocket.receive_text())
    except WebSocketDisconnect:
        pass
