"""The wizard console's live feed: ``/ws/sessions/{id}`` (staff login via the cookie).

On connect: ``{"type": "snapshot", "session": ...}``. Then, for every committed change, each
new event as ``{"type": "event", "event": ...}`` followed by a fresh snapshot; anything else
published on the session's channel with ``hub.publish(session_channel(id), message)``
(e.g. worker telemetry) is forwarded as it is, without a snapshot.
"""

from __future__ import annotations

from typing import Any

from fastapi import WebSocket
from fastapi.concurrency import run_in_threadpool
from sqlalchemy.orm import Session, sessionmaker

from chameleons.backend.auth import sessions as staff_sessions
from chameleons.backend.auth.socket_revocation import serve_while_signed_in
from chameleons.backend.events import live
from chameleons.backend.events.hub import LiveHub, Message, session_channel
from chameleons.backend.events.unit_of_work import write_session
from chameleons.backend.phone import devices
from chameleons.backend.routing import make_router
from chameleons.backend.sessions.flow import load
from chameleons.backend.sessions.snapshot import session_snapshot
from chameleons.backend.studies.errors import NotFoundError

router = make_router(tags=["sessions"])


def _staff_session(factory: sessionmaker[Session], cookie: dict[str, Any]) -> int | None:
    with factory() as db:
        found = staff_sessions.signed_in(db, cookie)
        return found[1] if found is not None else None


def _snapshot(
    factory: sessionmaker[Session], hub: LiveHub, session_id: int, base_url: str
) -> Message:
    with write_session(factory, hub) as db:
        flow = load(db, session_id, lock=False)
        phones = devices.phones(hub, session_id)
        return {"type": "snapshot", "session": session_snapshot(flow, base_url, phones)}


@router.websocket("/ws/sessions/{session_id}")
async def wizard_socket(websocket: WebSocket, session_id: int) -> None:
    factory = websocket.app.state.sessionmaker
    cookie = dict(websocket.session)
    staff_session = None
    if live.same_origin(websocket):
        staff_session = await run_in_threadpool(_staff_session, factory, cookie)
    if staff_session is None:
        await websocket.close(code=4401)
        return
    # Closed with 4401 when this login ends (logout, deactivation): not only at the handshake.
    await serve_while_signed_in(websocket, staff_session, lambda: _serve(websocket, session_id))


async def _serve(websocket: WebSocket, session_id: int) -> None:
    factory = websocket.app.state.sessionmaker
    hub: LiveHub = websocket.app.state.live_hub
    base_url = live.base_url(websocket)
    try:
        first = await run_in_threadpool(_snapshot, factory, hub, session_id, base_url)
    except NotFoundError:
        await websocket.close(code=4404)
        return
    await websocket.accept()
    async with hub.subscribe(session_channel(session_id)) as subscription:
        await live.send_json(websocket, first)

        async def on_change(messages: list[Message]) -> bool:
            for message in messages:
                if message.get("type") != "resync":
                    await live.send_json(websocket, message)
            # Telemetry and other pass-through messages change nothing stored: no snapshot.
            if any(m.get("type") in ("event", "resync") for m in messages):
                snapshot = await run_in_threadpool(_snapshot, factory, hub, session_id, base_url)
                await live.send_json(websocket, snapshot)
            return False

        await live.serve(websocket, subscription, on_change)
