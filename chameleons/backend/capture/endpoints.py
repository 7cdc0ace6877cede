"""``/ws/capture/<booth>?token=<key>``: the capture page's WebSocket (protocol: ``relay``).

Face frames go on to the booth's worker through the bridge at once (no acks: a frame the
worker cannot take now is dropped and counted); the calibration step is a command with an
ack, answered to the page. When the page goes, the worker hears so (its capture source is
then disconnected, as a phone that stopped sending).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import time
from collections.abc import Mapping
from typing import Any

from fastapi import WebSocket, WebSocketDisconnect
from starlette.concurrency import run_in_threadpool

from chameleons.backend.capture import links
from chameleons.backend.capture.relay import (
    MAX_BINARY,
    CaptureLink,
    CaptureProtocolError,
    parse_text,
)
from chameleons.backend.db import session_scope
from chameleons.backend.display.tokens import is_valid_booth
from chameleons.backend.events import guard
from chameleons.backend.routing import make_router
from chameleons.backend.wizard.worker_link import bridge_of, send_command
from chameleons.worker.control import CALIBRATE_WEBCAM
from chameleons.worker.envelope import Message

router = make_router(tags=["capture"])
log = logging.getLogger(__name__)
REPORT_SECONDS = 1.0
RECHECK_SECONDS = 2.0  # a rotated or retired link closes open pages within this long
CALIBRATION_TIMEOUT = 3.0


@router.websocket("/ws/capture/{booth}")
async def capture_socket(websocket: WebSocket, booth: str, token: str | None = None) -> None:
    if token is None or not (
        is_valid_booth(booth) and await run_in_threadpool(_token_works, websocket, booth, token)
    ):
        await websocket.close(code=guard.POLICY_VIOLATION)
        return
    await websocket.accept()
    link = CaptureLink(booth)
    async with guard.guarded(websocket):
        await guard.send_text(websocket, json.dumps({"type": "hello", "booth": booth}))
        try:
            await _serve(websocket, link, token)
        finally:
            await _relay(websocket, link, link.status(None, time.monotonic(), connected=False))


def _token_works(websocket: WebSocket, booth: str, token: str) -> bool:
    with session_scope(websocket.app.state.sessionmaker) as db:
        return links.token_works(db, websocket.app, booth, token)


async def _relay(websocket: WebSocket, link: CaptureLink, message: Message) -> bool:
    bridge = bridge_of(websocket.app.state)
    sent = bridge is not None and await bridge.relay(link.booth, message)
    if not sent:
        link.unrelayed += 1
    return bool(sent)


async def _serve(websocket: WebSocket, link: CaptureLink, token: str) -> None:
    tasks = {asyncio.create_task(_receive(websocket, link)),
             asyncio.create_task(_report(websocket, link, token))}  # fmt: skip
    try:
        await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        guard.raise_closed(tasks)
    finally:
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task


def _worker_connected(websocket: WebSocket, booth: str) -> bool:
    bridge = bridge_of(websocket.app.state)
    if bridge is None:
        return False
    info = bridge.workers().get(booth)
    return info is not None and bool(info.connected(bridge.stale_after))


async def _report(websocket: WebSocket, link: CaptureLink, token: str) -> None:
    """Once a second: what reached the server, and whether the booth's worker is there;
    every :data:`RECHECK_SECONDS` whether the link still works (the PI may have issued a
    new one or retired the booth: the page is then closed with 1008)."""
    checked = time.monotonic()
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            await asyncio.sleep(REPORT_SECONDS)
            if time.monotonic() - checked >= RECHECK_SECONDS:
                checked = time.monotonic()
                if not await run_in_threadpool(_token_works, websocket, link.booth, token):
                    raise guard.SocketClosed(guard.POLICY_VIOLATION,
                                             "capture link rotated or retired")  # fmt: skip
            report = link.report(_worker_connected(websocket, link.booth))
            await guard.send_text(websocket, json.dumps(report))


async def _receive(websocket: WebSocket, link: CaptureLink) -> None:
    limits = guard.limits_of(websocket)
    rate = guard.MessageRate(limits.rate, limits.burst)
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            frame = await websocket.receive()
            if frame["type"] == "websocket.disconnect":
                return
            if not rate.allow():
                raise guard.SocketClosed(guard.POLICY_VIOLATION, "too many capture messages")
            try:
                reply = await _handle(websocket, link, frame, time.monotonic())
            except CaptureProtocolError as exc:
                link.bad += 1
                log.debug("capture page of %s: %s", link.booth, exc)
                continue
            if isinstance(reply, dict):
                await guard.send_text(websocket, json.dumps(reply))


async def _handle(websocket: WebSocket, link: CaptureLink, frame: Mapping[str, Any],
                  now: float) -> dict[str, Any] | bool | None:  # fmt: skip
    """A reply for the page, whether the worker took a relayed message, or None."""
    data = frame.get("bytes")
    if data is not None:
        if len(data) > MAX_BINARY:
            raise CaptureProtocolError("a face frame too large")
        return await _relay(websocket, link, link.landmarks(data, now))
    message = parse_text(str(frame.get("text") or ""))
    kind = message["type"]
    if kind == "no_face":
        return await _relay(websocket, link, link.no_face_message(message, now))
    if kind == "status":
        return await _relay(websocket, link, link.status(message, now))
    if kind == "ping":
        return {"type": "pong", "t": message.get("t")}
    if kind == "calibrate":
        return await _calibrate(websocket, link, str(message["action"]))
    raise CaptureProtocolError(f"unknown message type {kind!r}")


async def _calibrate(websocket: WebSocket, link: CaptureLink, action: str) -> dict[str, Any]:
    outcome = await asyncio.shield(send_command(
        bridge_of(websocket.app.state), link.booth, CALIBRATE_WEBCAM, {"action": action},
        timeout=CALIBRATION_TIMEOUT,
    ))  # fmt: skip
    if not outcome.sent:
        return {"type": "calibration", "action": action, "calibrated": False,
                "problem": outcome.detail}  # fmt: skip
    return {"type": "calibration", "action": action, **(outcome.result or {})}
