"""The robot's health as the console's strip shows it: checks from the worker's telemetry,
each ok or failing, and since when it has been failing.

A failing check is ``degraded`` (amber) until it has failed for the grace period
(``Settings.health_alarm_after_s``), then an ``alarm`` (red): a short dip of the frame
rate or the jitter on a busy PC is not worth interrupting the wizard. A worker that is
gone or a robot that is disconnected is an alarm at once. The limits are settings
(``health_*``), defaults in :class:`Thresholds`.

The chips, their levels and order are in :mod:`.health_checks`, the robots' and typed
speech's chips in :mod:`.robot_health`; this module builds the worker's (face stream,
renderer, jitter, recording, robot face, phone timecode) and keeps every name the rest of
the server imports from it.

``HealthTracker`` keeps the "failing since" moments per booth on ``app.state``, so a
reloaded console still shows how long an alarm has been on.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from chameleons.backend.wizard.health_checks import (
    ALARM,
    ALARM_AT_ONCE,
    CHECKS,
    DISPLAY,
    FURHAT,
    LABELS,
    NEVER_ALARM,
    NOMINAL_TICK_HZ,
    ORDER,
    STALE_AFTER_SECONDS,
    Check,
    Needs,
    Thresholds,
    flag,
    fmt,
    number,
)
from chameleons.backend.wizard.robot_health import (
    needed_robots,
    output_check,
    robot_check,
    robot_value,
    typed_speech_check,
)

__all__ = [
    "ALARM_AT_ONCE",
    "CHECKS",
    "DISPLAY",
    "FURHAT",
    "LABELS",
    "NEVER_ALARM",
    "ORDER",
    "STALE_AFTER_SECONDS",
    "Check",
    "HealthTracker",
    "Needs",
    "Thresholds",
    "evaluate",
    "output_check",
    "robot_value",
    "tracker_of",
]


def evaluate(
    telemetry: Mapping[str, Any] | None,
    age: float | None,
    limits: Thresholds | None = None,
    display: tuple[bool, str] | None = None,
    synthesiser: tuple[bool, str] | None = None,
    needs: Needs | None = None,
) -> dict[str, Check]:
    """The checks for the latest telemetry (``None``: nothing received) of ``age`` seconds.
    ``display``: whether the booth's robot display page is open and playing, and why not
    (:meth:`DisplayChannel.presence`); for the virtual robot that *is* the robot.
    ``synthesiser``: whether the server can synthesise typed speech (espeak-ng), and the
    sentence saying so (:func:`typed_speech.check_synthesiser`); None: not checked.
    ``needs``: the robots the booth's study runs conditions on (:func:`robots_needed`):
    on a booth with both robots the one not driven now gets a chip of its own when a
    condition needs it (None: not known, no such chip)."""
    limits = limits or Thresholds()
    speech = typed_speech_check(telemetry, synthesiser)
    if telemetry is None or age is None or age > STALE_AFTER_SECONDS:
        why = "no telemetry" if telemetry is None else f"silent {age:.0f} s"
        checks = {name: Check(name, None, "unknown") for name in (*CHECKS, "speaking")}
        checks["worker"] = Check("worker", False, why)
        return {**checks, **speech}
    fps = number(telemetry, "input_fps")
    tick = number(telemetry, "tick_rate_hz")
    nominal = number(telemetry, "tick_target_hz") or NOMINAL_TICK_HZ
    jitter = number(telemetry, "jitter_ms.p99")
    robot = flag(telemetry, "robot_connected")
    speaking = flag(telemetry, "speaking")
    tick_ok = tick is not None and tick >= limits.min_tick_ratio * nominal
    jitter_ok = jitter is not None and jitter <= limits.max_jitter_p99_ms
    fps_ok = fps is not None and fps >= limits.min_face_fps
    return {
        "worker": Check("worker", True, "connected"),
        "input": Check("input", fps_ok, _input_value(telemetry, fps, fps_ok)),
        "tick": Check("tick", tick_ok, fmt(tick, "Hz")),
        "jitter": Check("jitter", jitter_ok, fmt(jitter, "ms p99", 2)),
        "robot": robot_check(telemetry, robot is True, display),
        **needed_robots(telemetry, display, needs),
        **_recording_check(telemetry),
        "speaking": Check("speaking", True, "speaking" if speaking else "quiet"),
        **_face_check(telemetry),
        **_timecode_check(telemetry),
        **speech,
    }


def _input_value(telemetry: Mapping[str, Any], fps: float | None, fps_ok: bool) -> str:
    """The frame rate, or why the phone sends no faces: it sees no face, or the lab must
    change the app's mode (e.g. MetaHuman Animator instead of ARKit streaming)."""
    ingest = telemetry.get("ingest")
    ingest = ingest if isinstance(ingest, Mapping) else {}
    if not fps_ok and ingest.get("problem"):
        return str(ingest["problem"])
    if not fps_ok and ingest.get("no_face"):
        return "camera sees no face" if _webcam(ingest) else "phone sees no face"
    if _webcam(ingest):
        receiver = (ingest.get("receivers") or {}).get(ingest["source"]) or {}
        calibration = receiver.get("calibration") if isinstance(receiver, Mapping) else None
        return fmt(fps, "fps") + " from the webcam" + (
            f" ({calibration})" if calibration else "")  # fmt: skip
    return fmt(fps, "fps") + _sender(ingest.get("pairing"))


def _webcam(ingest: Mapping[str, Any]) -> bool:
    return str(ingest.get("source") or "").startswith("webcam")


def _sender(pairing: Any) -> str:
    """Which phone the stream is from, and how many packets other senders sent (dropped)."""
    if not isinstance(pairing, Mapping):
        return ""
    sender = pairing.get("sender")
    text = f" from {sender}" if sender else " (no phone paired yet)"
    others = pairing.get("other_packets")
    if isinstance(others, int) and others > 0:
        text += f"; {others} packets from other senders ignored (last {pairing.get('last_other')})"
    return text


def _recording_check(telemetry: Mapping[str, Any]) -> dict[str, Check]:
    """Red with the worker's sentence when recordings cannot be written (read-only folder,
    full disk); otherwise whether an interaction is being recorded. No chip for a worker
    that reports no recorder."""
    recording = telemetry.get("recording")
    if not isinstance(recording, Mapping) or not recording:
        return {}
    if recording.get("problem"):
        return {"recording": Check("recording", False, str(recording["problem"]))}
    if not recording.get("active"):
        return {"recording": Check("recording", True, "idle")}
    frames = recording.get("frames")
    count = frames.get("participant") if isinstance(frames, Mapping) else None
    value = "recording" if count is None else f"recording, {count} frames"
    return {"recording": Check("recording", True, value)}


def _robot_face(telemetry: Mapping[str, Any]) -> Mapping[str, Any]:
    face = telemetry.get("robot_face")
    return face if isinstance(face, Mapping) else {}


def _face_check(telemetry: Mapping[str, Any]) -> dict[str, Check]:
    """A chip only when the robot's face needs attention: a study face id with no robot
    face mapped (the robot got the id unchanged), or a face setting the robot refused."""
    face = _robot_face(telemetry)
    unmapped, refused = face.get("unmapped_face"), face.get("refused") or {}
    problems = [f"{unmapped} not mapped to a robot face"] if unmapped else []
    if isinstance(refused, Mapping):
        problems += [f"{name} refused ({why})" for name, why in refused.items()]
    if not problems:
        return {}
    return {"face": Check("face", False, "; ".join(problems))}


def _timecode_check(telemetry: Mapping[str, Any]) -> dict[str, Check]:
    """A chip only while the capture does not trust the phone's timecode (frozen, jumping,
    drifting): the copy then runs on arrival times, with the network's jitter in them."""
    ingest = telemetry.get("ingest")
    problem = ingest.get("timecode_problem") if isinstance(ingest, Mapping) else None
    if not problem:
        return {}
    return {"timecode": Check("timecode", False, f"{problem}: copying on arrival times")}


@dataclass
class HealthTracker:
    """When each check of each booth started failing (monotonic seconds)."""

    since: dict[tuple[str, str], float] = field(default_factory=dict)
    limits: Thresholds = field(default_factory=Thresholds)

    def snapshot(
        self,
        booth: str,
        telemetry: Mapping[str, Any] | None,
        age: float | None,
        now: float | None = None,
        display: tuple[bool, str] | None = None,
        synthesiser: tuple[bool, str] | None = None,
        needs: Needs | None = None,
        extra: Mapping[str, Check] | None = None,
    ) -> dict[str, Any]:
        """``extra``: checks from elsewhere than the worker (the participant video's)."""
        moment = time.monotonic() if now is None else now
        checks = {**evaluate(telemetry, age, self.limits, display, synthesiser, needs),
                  **(extra or {})}  # fmt: skip
        for check in checks.values():
            key = (booth, check.id)
            if check.ok is False:
                check.grade(moment - self.since.setdefault(key, moment), self.limits.alarm_after_s)
            else:
                self.since.pop(key, None)
                check.grade(None, self.limits.alarm_after_s)
        return {
            "type": "health",
            "booth": booth,
            "ok": all(check.ok is not False for check in checks.values()),
            "alarm": any(check.level == ALARM for check in checks.values()),
            "alarm_after_s": self.limits.alarm_after_s,
            "checks": [checks[name].as_dict() for name in ORDER if name in checks],
            "telemetry": dict(telemetry) if telemetry is not None else None,
            # How long ago the worker sampled its speaking state: the console lets a speech
            # event newer than that decide the Speaking chip.
            "speaking_age_s": _speaking_age(telemetry, age),
        }


def _speaking_age(telemetry: Mapping[str, Any] | None, age: float | None) -> float | None:
    """The age of the heartbeat's speaking flag: the heartbeat's own age plus that of the
    renderer's statistics it repeats (both come once a second, so the flag alone lagged
    the robot by up to two seconds, and the server's 1 Hz relay added a third)."""
    if telemetry is None or age is None:
        return None
    stage = number(telemetry, "stages.renderer")
    return round(age + (stage or 0.0), 3)


def tracker_of(state: Any) -> HealthTracker:
    tracker: HealthTracker | None = getattr(state, "wizard_health", None)
    if tracker is None:
        settings = getattr(state, "settings", None)
        limits = Thresholds.from_settings(settings) if settings is not None else Thresholds()
        tracker = state.wizard_health = HealthTracker(limits=limits)
    return tracker
