"""``chameleons worker --check``: log in to the Furhat and list the study's face mapping
against the faces the robot reports (``request.face.status`` with ``face_id`` and
``face_list``, as Furhat's own client asks for them; see docs/furhat.md)."""

from __future__ import annotations

import asyncio
import json
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from websockets.asyncio.client import ClientConnection, connect
from websockets.exceptions import WebSocketException


@dataclass(frozen=True)
class FaceRow:
    study_face: str
    robot_face: str
    on_robot: bool | None  # None: the robot's list is unknown


@dataclass
class RobotCheck:
    url: str
    problem: str | None = None  # could not connect or log in
    current_face: str | None = None
    robot_faces: list[str] = field(default_factory=list)
    rows: list[FaceRow] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.problem is None and all(row.on_robot for row in self.rows)

    def lines(self) -> list[str]:
        if self.problem is not None:
            return [f"robot {self.url}: {self.problem}"]
        out = [f"robot {self.url}: logged in; current face {self.current_face or '?'}; "
               f"{len(self.robot_faces)} faces on the robot"]  # fmt: skip
        if not self.rows:
            out.append("no study faces mapped (--furhat-face / CHAMELEONS_WORKER_FURHAT_FACES):"
                       " study face ids are sent unchanged")  # fmt: skip
        for row in self.rows:
            mark = {True: "ok", False: "NOT ON THE ROBOT", None: "unknown (no face list)"}[
                row.on_robot
            ]
            out.append(f"  {row.study_face} -> {row.robot_face}: {mark}")
        missing = [row.robot_face for row in self.rows if not row.on_robot]
        if missing:
            out.append("robot faces: " + ", ".join(self.robot_faces))
        return out


async def check_furhat(
    url: str, key: str | None, faces: Mapping[str, str], timeout: float = 5.0
) -> RobotCheck:
    report = RobotCheck(url)
    try:
        async with connect(url, open_timeout=timeout) as ws:
            auth: dict[str, Any] = {"type": "request.auth"}
            if key:
                auth["key"] = key
            reply = await _ask(ws, auth, "response.auth", timeout)
            if reply is None:
                report.problem = f"the robot did not answer the login within {timeout:g} s"
                return report
            if reply.get("access") is not True:
                report.problem = "the robot refused the login (wrong or missing key)"
                return report
            ask = {"type": "request.face.status", "face_id": True, "face_list": True}
            status = await _ask(ws, ask, "response.face.status", timeout)
    except (OSError, TimeoutError, WebSocketException) as exc:
        report.problem = f"cannot connect: {exc}"
        return report
    listed = status.get("face_list") if status else None
    report.robot_faces = [str(f) for f in listed] if isinstance(listed, list) else []
    report.current_face = str(status.get("face_id")) if status and status.get("face_id") else None
    known = set(report.robot_faces) if isinstance(listed, list) else None
    report.rows = [FaceRow(study, robot, None if known is None else robot in known)
                   for study, robot in sorted(faces.items())]  # fmt: skip
    return report


async def _ask(
    ws: ClientConnection, message: dict[str, Any], answer: str, timeout: float
) -> dict[str, Any] | None:
    """Send with a ``request_id``; the first ``answer`` reply that carries it (or none)."""
    request_id = uuid.uuid4().hex
    await ws.send(json.dumps({**message, "request_id": request_id}))
    try:
        async with asyncio.timeout(timeout):
            while True:
                try:
                    reply = json.loads(await ws.recv())
                except ValueError:
                    continue
                if isinstance(reply, dict) and reply.get("type") == answer and \
                        reply.get("request_id") in (None, request_id):  # fmt: skip
                    return reply
    except TimeoutError:
        return None


def run_check(url: str, key: str | None, faces: Mapping[str, str]) -> RobotCheck:
    return asyncio.run(check_furhat(url, key, faces))
