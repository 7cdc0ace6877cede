"""What the bridge knows about each booth: its worker, and the state set through it."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

from chameleons.worker.control import SET_BEHAVIOUR, SET_FACE, START_RECORDING, STOP_RECORDING


@dataclass
class BoothState:
    """The last behaviour, face and open recording a booth was given (acknowledged)."""

    behaviour: dict[str, Any] | None = None
    face: dict[str, Any] | None = None
    recording: dict[str, Any] | None = None

    def record(self, command: str, body: dict[str, Any]) -> None:
        if command == SET_BEHAVIOUR:
            self.behaviour = dict(body)
        elif command == SET_FACE:
            self.face = dict(body)
        elif command == START_RECORDING:
            self.recording = dict(body)
        elif command == STOP_RECORDING:
            self.recording = None

    def commands(self) -> list[tuple[str, dict[str, Any]]]:
        """The commands that bring a fresh worker to this state, in a sensible order."""
        plan = [(SET_FACE, self.face), (SET_BEHAVIOUR, self.behaviour),
                (START_RECORDING, self.recording)]  # fmt: skip
        return [(kind, dict(body)) for kind, body in plan if body is not None]

    def __bool__(self) -> bool:
        return bool(self.commands())


@dataclass
class WorkerInfo:
    booth: str
    instance: str
    hello: dict[str, Any]
    first_seen: float = field(default_factory=time.monotonic)
    last_seen: float = field(default_factory=time.monotonic)
    restarts: int = 0
    telemetry: dict[str, Any] | None = None
    telemetry_at: float = 0.0
    lost_reported: bool = False
    replays: int = 0  # state replays completed after restarts

    def connected(self, stale_after: float) -> bool:
        return time.monotonic() - self.last_seen < stale_after

    def restart(self, instance: str, hello: dict[str, Any]) -> None:
        self.instance, self.hello = instance, hello
        self.restarts += 1
        self.telemetry = None

    def summary(self, stale_after: float) -> dict[str, Any]:
        return {"booth": self.booth, "instance": self.instance, "restarts": self.restarts,
                "replays": self.replays,
                "connected": self.connected(stale_after),
                "last_seen_s": round(time.monotonic() - self.last_seen, 3),
                "hello": self.hello}  # fmt: skip
