"""The health strip's chips and what grades them: a :class:`Check` (ok, failing or
unknown, and its level), the checks' labels and order, the limits (:class:`Thresholds`),
and the small readers of the worker's telemetry the checks share.

A failing check is ``degraded`` (amber) until it has failed for the grace period
(``Settings.health_alarm_after_s``), then an ``alarm`` (red); the checks in
:data:`ALARM_AT_ONCE` are an alarm at once, those in :data:`NEVER_ALARM` never. The
checks themselves are built in :mod:`.health` (the worker's) and :mod:`.robot_health`
(the robots' and typed speech's).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

STALE_AFTER_SECONDS = 3.0  # heartbeats come at 1 Hz: three missed ones mean "gone"
NOMINAL_TICK_HZ = 125.0
# Nothing reaches the robot, or nothing is recorded: no grace.
ALARM_AT_ONCE = frozenset({"worker", "robot", "recording"})
# A fallback the session can run without, or the robot a later condition needs (a booth
# with both robots): amber for as long as it fails, never an alarm.
NEVER_ALARM = frozenset({"typed_speech", "display", "furhat", "video"})
# The robots of a booth with both (driver virtual+furhat), as its heartbeat names them.
DISPLAY, FURHAT = "display", "furhat"
ROBOT_NAMES = {DISPLAY: "the display", FURHAT: "the Furhat"}
# Which robots a booth's study needs: robot (display/furhat) -> the conditions run on it.
Needs = Mapping[str, Sequence[str]]
OK, UNKNOWN, DEGRADED, ALARM = "ok", "unknown", "degraded", "alarm"


@dataclass(frozen=True)
class Thresholds:
    """Limits of the checks (defaults as in :class:`chameleons.settings.Settings`)."""

    max_jitter_p99_ms: float = 5.0
    min_face_fps: float = 20.0
    min_tick_ratio: float = 0.9  # of the nominal tick rate
    alarm_after_s: float = 3.0

    @classmethod
    def from_settings(cls, settings: Any) -> Thresholds:
        return cls(
            max_jitter_p99_ms=float(settings.health_max_jitter_p99_ms),
            min_face_fps=float(settings.health_min_face_fps),
            min_tick_ratio=float(settings.health_min_tick_ratio),
            alarm_after_s=float(settings.health_alarm_after_s),
        )


CHECKS = ("worker", "input", "tick", "jitter", "robot")
LABELS = {
    "worker": "Worker",
    "input": "Face stream",
    "tick": "Renderer",
    "jitter": "Jitter",
    "robot": "Robot",
    "display": "Robot display",
    "furhat": "Furhat",
    "recording": "Recording",
    "video": "Participant video",
    "speaking": "Speaking",
    "face": "Robot face",
    "timecode": "Phone timecode",
    "typed_speech": "Typed speech",
}
ORDER = (*CHECKS, DISPLAY, FURHAT, "recording", "video", "speaking", "face", "timecode",
         "typed_speech")
ROBOT_PROBLEMS = {"auth_refused": "login refused", "auth_timeout": "login not answered"}


@dataclass
class Check:
    """``ok`` None means unknown (the worker is silent, so its parts cannot be judged).
    ``since_s``: seconds since something the value counts from (the participant video's
    last chunk), sent apart from the value so that its ticking is no change."""

    id: str
    ok: bool | None
    value: str
    failing_for: float | None = None
    level: str = UNKNOWN
    since_s: float | None = None

    def as_dict(self) -> dict[str, Any]:
        found = {
            "id": self.id,
            "label": LABELS[self.id],
            "ok": self.ok,
            "level": self.level,
            "value": self.value,
            "failing_for": None if self.failing_for is None else round(self.failing_for, 1),
        }
        if self.since_s is not None:
            found["since_s"] = round(self.since_s, 1)
        return found

    def grade(self, failing_for: float | None, alarm_after_s: float) -> None:
        """Set ``failing_for`` and the level it gives."""
        self.failing_for = failing_for
        if self.ok is None:
            self.level = UNKNOWN
        elif self.ok:
            self.level = OK
        elif self.id in NEVER_ALARM:
            self.level = DEGRADED
        elif self.id in ALARM_AT_ONCE or (failing_for or 0.0) >= alarm_after_s:
            self.level = ALARM
        else:
            self.level = DEGRADED


def number(data: Mapping[str, Any], *names: str) -> float | None:
    """The first of ``names`` present as a number (dots walk into nested mappings)."""
    for name in names:
        value: Any = data
        for part in name.split("."):
            value = value.get(part) if isinstance(value, Mapping) else None
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
    return None


def flag(data: Mapping[str, Any], *names: str) -> bool | None:
    for name in names:
        value = data.get(name)
        if isinstance(value, bool):
            return value
        if isinstance(value, str):
            return value in ("connected", "open", "ok", "true")
    return None


def fmt(value: float | None, unit: str, digits: int = 1) -> str:
    return "unknown" if value is None else f"{value:.{digits}f} {unit}"
