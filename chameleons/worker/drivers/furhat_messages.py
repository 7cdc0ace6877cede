"""The Furhat Realtime API's messages as :mod:`.furhat` writes and reads them (JSON over the
WebSocket; checked against the vendor's client, see docs/furhat.md): the login, the face
set-up, the face stream (blendshape parameters, head pose) and reading a reply."""

from __future__ import annotations

import json
from collections.abc import Iterable
from typing import Any

# Idle behaviour the project switches off, in fields the vendor's client does not send.
UNCERTAIN_FACE_FIELDS = ("blinking", "head_sway")


def auth_request(key: str | None) -> dict[str, Any]:
    auth: dict[str, Any] = {"type": "request.auth"}
    if key:
        auth["key"] = key
    return auth


def face_config(robot_face_id: str | None) -> dict[str, Any]:
    """Only the fields the vendor's client sends (the face, visible, no microexpressions)."""
    config: dict[str, Any] = {"type": "request.face.config", "visibility": True,
                              "microexpressions": False}  # fmt: skip
    if robot_face_id:
        config["face_id"] = robot_face_id
    return config


def field_request(name: str, request_id: str) -> dict[str, Any]:
    """One uncertain face field switched off, in a message of its own."""
    return {"type": "request.face.config", name: False, "request_id": request_id}


def headpose(yaw: float, pitch: float, roll: float) -> str:
    return json.dumps({"type": "request.face.headpose", "yaw": round(yaw, 3),
                       "pitch": round(pitch, 3), "roll": round(roll, 3),
                       "relative": False})  # fmt: skip


def face_params(names: Iterable[str], values: Iterable[Any]) -> str:
    """Blendshape parameters by the robot's names (``JAW_OPEN``), rounded to 4 places."""
    params = {name: round(float(v), 4) for name, v in zip(names, values, strict=True)}
    return json.dumps({"type": "request.face.params", "params": params})


def decode(raw: str | bytes) -> dict[str, Any]:
    """A reply as a dict; anything else (not JSON, not an object) as an empty one."""
    try:
        message = json.loads(raw)
    except ValueError:
        return {}
    return message if isinstance(message, dict) else {}
