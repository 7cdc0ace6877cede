"""Which phones have the participant's link open, and sending an extra one away.

A link opened on two phones (a participant who scanned the QR code twice, a companion's
phone) shows up on the wizard console as two phones. Each phone page names itself with a
random device id kept in its local storage (a reload stays the same phone); the wizard
can disconnect one. That phone then reads "This link is open on another phone" and is
refused while another phone holds the link, so a reload does not bring it back; once no
other phone is connected, it may join again (the wizard may have sent the wrong one away).
"""

from __future__ import annotations

import re
import secrets
from datetime import UTC, datetime
from typing import Any

from chameleons.backend.events.hub import LiveHub, Message, session_channel
from chameleons.backend.sessions.flow import Flow
from chameleons.backend.sessions.snapshot import phone_presence_key
from chameleons.backend.studies.errors import NotFoundError

SENT_AWAY_CODE = 4409  # the phone page shows SENT_AWAY_MESSAGE and stops reconnecting
SENT_AWAY_TYPE = "phone.sent_away"
SENT_AWAY_MESSAGE = (
    "This link is open on another phone. Please continue on that phone, or ask the "
    "experimenter if this is the phone you should use."
)
_DEVICE_ID = re.compile(r"^[0-9a-f]{8,32}$")


def device_id(raw: str | None) -> str:
    """The phone's own id when it sent a well-formed one, else a fresh one."""
    if raw and _DEVICE_ID.fullmatch(raw):
        return raw
    return secrets.token_hex(8)


def label(user_agent: str) -> str:
    """A few words telling phones apart on the console, from the browser's user agent."""
    for needle, name in (("iPhone", "iPhone"), ("iPad", "iPad"), ("Android", "Android")):
        if needle in user_agent:
            return name
    for needle, name in (("Firefox", "Firefox"), ("Edg", "Edge"), ("Chrom", "Chrome")):
        if needle in user_agent:
            return name
    return "Safari" if "Safari" in user_agent else "browser"


def detail(device: str, user_agent: str) -> Message:
    return {
        "id": device,
        "label": label(user_agent),
        "connected_at": datetime.now(UTC).isoformat(),
    }


def phones(hub: LiveHub, session_id: int) -> list[Message]:
    """The phones on the session's link, oldest first; the later ones are marked ``extra``."""
    key = phone_presence_key(session_id)
    present = hub.present_details(key)
    # Another server process whose presence came without details (too large to relay):
    # counted, listed without an id (it cannot be disconnected from here).
    unknown = {"id": None, "label": "phone on another server process", "connected_at": None}
    present += [dict(unknown) for _ in range(hub.present(key) - len(present))]
    return [
        {**phone, "number": number, "extra": number > 1}
        for number, phone in enumerate(present, start=1)
    ]


def sent_away_message(device: str) -> Message:
    return {"type": SENT_AWAY_TYPE, "device": device}


def is_sent_away(messages: list[Message], device: str) -> bool:
    return any(m.get("type") == SENT_AWAY_TYPE and m.get("device") == device for m in messages)


def _refusals(app_state: Any) -> dict[int, set[str]]:
    refused: dict[int, set[str]] | None = getattr(app_state, "phones_sent_away", None)
    if refused is None:
        refused = app_state.phones_sent_away = {}
    return refused


def remember_sent_away(app_state: Any, session_id: int, device: str) -> None:
    _refusals(app_state).setdefault(session_id, set()).add(device)


def refused(app_state: Any, hub: LiveHub, session_id: int, device: str) -> bool:
    """Whether this phone was sent away and another phone still holds the link."""
    sent = _refusals(app_state).get(session_id, set())
    if device not in sent:
        return False
    if hub.present(phone_presence_key(session_id)) > 0:
        return True
    sent.discard(device)  # nobody else holds the link: this phone may join again
    return False


def send_away(app_state: Any, hub: LiveHub, flow: Flow, device: str) -> None:
    """Disconnect ``device`` from the session's link (logged); the other phones stay."""
    present = phones(hub, flow.session.id)
    phone = next((p for p in present if p["id"] == device), None)
    if phone is None:
        raise NotFoundError("That phone is no longer connected to this link.")
    if len(present) < 2:
        raise flow.refuse(
            "Only one phone is on this link: disconnecting it would leave the participant "
            "without one."
        )
    remember_sent_away(app_state, flow.session.id, device)
    flow.log(
        "phone.sent_away",
        payload={"device": device, "label": phone["label"], "number": phone["number"]},
    )
    hub.publish(session_channel(flow.session.id), sent_away_message(device))
