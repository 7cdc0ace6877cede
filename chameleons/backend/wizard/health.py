"""The robot's health as the console's strip shows it: checks from the worker's telemetry,
each ok or failing, and since when it has been failing.

A failing check is ``degraded`` (amber) until it has failed for the grace period
(``Settings.health_alarm_after_s``), then an ``alarm`` (red): a short dip of the frame
rate or the jitter on a busy PC is not worth interrupting the wizard. A worker that is
gone or a robot that is disconnected is an alarm at once. The limits are settings
(``health_*``), defaults in :class:`Thresholds`.

``HealthTracker`` keeps the "failing since" moments per booth on ``app.state``, so a
reloaded console still shows how long an alarm has been on.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from chameleons.worker.drivers import renderers, speaks_text

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


def _number(data: Mapping[str, Any], *names: str) -> float | None:
    """The first of ``names`` present as a number (dots walk into nested mappings)."""
    for name in names:
        value: Any = data
        for part in name.split("."):
            value = value.get(part) if isinstance(value, Mapping) else None
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
    return None


def _flag(data: Mapping[str, Any], *names: str) -> bool | None:
    for name in names:
        value = data.get(name)
        if isinstance(value, bool):
            return value
        if isinstance(value, str):
            return value in ("connected", "open", "ok", "true")
    return None


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
    speech = _typed_speech_check(telemetry, synthesiser)
    if telemetry is None or age is None or age > STALE_AFTER_SECONDS:
        why = "no telemetry" if telemetry is None else f"silent {age:.0f} s"
        checks = {name: Check(name, None, "unknown") for name in (*CHECKS, "speaking")}
        checks["worker"] = Check("worker", False, why)
        return {**checks, **speech}
    fps = _number(telemetry, "input_fps")
    tick = _number(telemetry, "tick_rate_hz")
    nominal = _number(telemetry, "tick_target_hz") or NOMINAL_TICK_HZ
    jitter = _number(telemetry, "jitter_ms.p99")
    robot = _flag(telemetry, "robot_connected")
    speaking = _flag(telemetry, "speaking")
    tick_ok = tick is not None and tick >= limits.min_tick_ratio * nominal
    jitter_ok = jitter is not None and jitter <= limits.max_jitter_p99_ms
    fps_ok = fps is not None and fps >= limits.min_face_fps
    return {
        "worker": Check("worker", True, "connected"),
        "input": Check("input", fps_ok, _input_value(telemetry, fps, fps_ok)),
        "tick": Check("tick", tick_ok, _fmt(tick, "Hz")),
        "jitter": Check("jitter", jitter_ok, _fmt(jitter, "ms p99", 2)),
        "robot": _robot_check(telemetry, robot is True, display),
        **_needed_robots(telemetry, display, needs),
        **_recording_check(telemetry),
        "speaking": Check("speaking", True, "speaking" if speaking else "quiet"),
        **_face_check(telemetry),
        **_timecode_check(telemetry),
        **speech,
    }


def _typed_speech_check(
    telemetry: Mapping[str, Any] | None, synthesiser: tuple[bool, str] | None
) -> dict[str, Check]:
    """Whether the Say field can speak: a robot with its own text-to-speech (a Furhat) says
    typed sentences itself; any other needs espeak-ng on the server. A booth with both
    robots follows the one driven now: the display has no text-to-speech and skips typed
    text (``SwitchDriver``), so while it runs the Say field is not voiced."""
    driver = telemetry.get("driver") if telemetry is not None else None
    if isinstance(driver, str) and speaks_text(driver):
        active = telemetry.get("robot_active") if telemetry is not None else None
        if isinstance(telemetry.get("robot_outputs") if telemetry else None, Mapping):
            if active == DISPLAY:
                return {"typed_speech": Check("typed_speech", False, (
                    "not voiced while the display runs (it has no text-to-speech); the Furhat "
                    "speaks typed text in its conditions"))}  # fmt: skip
            if active == FURHAT:
                return {"typed_speech": Check("typed_speech", True, "the Furhat's own voice")}
        return {"typed_speech": Check("typed_speech", True, "the robot's own voice")}
    if synthesiser is None:
        return {}
    available, detail = synthesiser
    value = detail if available else f"{detail}: the Say field cannot speak"
    return {"typed_speech": Check("typed_speech", available, value)}


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
        return _fmt(fps, "fps") + " from the webcam" + (
            f" ({calibration})" if calibration else "")  # fmt: skip
    return _fmt(fps, "fps") + _sender(ingest.get("pairing"))


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


def _robot_check(
    telemetry: Mapping[str, Any], connected: bool, display: tuple[bool, str] | None
) -> Check:
    """The virtual robot is connected when a display page of the booth is open and
    playing, not merely when the worker runs; any other robot by its driver's state. On a
    booth with both robots (virtual+furhat) the robot driven now, and the chip says which."""
    if telemetry.get("driver") == "virtual" and display is not None:
        open_and_playing, why = display
        return Check("robot", open_and_playing, why)
    active = telemetry.get("robot_active")
    if isinstance(telemetry.get("robot_outputs"), Mapping) and active in (DISPLAY, FURHAT):
        check = output_check(telemetry, str(active), display)
        check.value += f" ({ROBOT_NAMES[str(active)]} runs now)"
        return check
    return Check("robot", connected, robot_value(telemetry, connected))


def output_check(
    telemetry: Mapping[str, Any], output: str, display: tuple[bool, str] | None,
    check_id: str = "robot",
) -> Check:  # fmt: skip
    """One robot of a booth with both (``display`` or ``furhat``), driven now or not: the
    display by its page (open and playing), the Furhat by its connection."""
    if output == DISPLAY:
        open_and_playing, why = display if display is not None else (
            False, "no robot display open")  # fmt: skip
        return Check(check_id, open_and_playing, why)
    outputs = telemetry.get("robot_outputs")
    stats = outputs.get(output) if isinstance(outputs, Mapping) else None
    if not isinstance(stats, Mapping):
        return Check(check_id, False, f"this booth's worker drives no Furhat (its driver is "
                     f"{telemetry.get('driver') or 'unknown'})")  # fmt: skip
    connected = stats.get("state") == "connected"
    words = robot_value({"robot_state": stats.get("state"), "robot_problem": stats.get("problem"),
                         "robot_retry_in": stats.get("retry_in")}, connected)  # fmt: skip
    return Check(check_id, connected, words)


def _needed_robots(
    telemetry: Mapping[str, Any], display: tuple[bool, str] | None, needs: Needs | None
) -> dict[str, Check]:
    """A chip for each robot the study's conditions run on that is not the one driven now
    (its own chip is *Robot*): missing, it says which conditions cannot run. A booth with
    the display only has no chip for a study's Furhat conditions but one saying it has no
    Furhat."""
    if not needs:
        return {}
    driver = str(telemetry.get("driver") or "")
    if needs.get(FURHAT) and FURHAT not in renderers(driver):
        names = ", ".join(needs[FURHAT])
        return {FURHAT: Check(FURHAT, False, f"this booth drives no Furhat (its worker's "
                              f"driver is {driver or 'unknown'}): {names} cannot run")}  # fmt: skip
    if not isinstance(telemetry.get("robot_outputs"), Mapping):
        return {}
    checks: dict[str, Check] = {}
    for output in (DISPLAY, FURHAT):
        conditions = needs.get(output)
        if not conditions or output == telemetry.get("robot_active"):
            continue
        check = output_check(telemetry, output, display, output)
        names = ", ".join(conditions)
        need = "needs" if len(conditions) == 1 else "need"
        check.value += f" (for {names})" if check.ok else f"; {names} {need} it"
        checks[output] = check
    return checks


def robot_value(telemetry: Mapping[str, Any], connected: bool) -> str:
    """``connected``, or why not: a refused or unanswered login says so with the robot's
    reason, and a robot the worker tries again says when (``retrying in 8 s``)."""
    if connected:
        return "connected"
    state = str(telemetry.get("robot_state") or "disconnected")
    problem = telemetry.get("robot_problem")
    retry_in = _number(telemetry, "robot_retry_in")
    if state == "connecting" and problem:  # a login that failed is being tried again
        return f"login failed: {problem}; trying again now"
    if state in ROBOT_PROBLEMS:
        value = f"{ROBOT_PROBLEMS[state]}: {problem}" if problem else ROBOT_PROBLEMS[state]
    else:
        value = "disconnected"
    return value if retry_in is None else f"{value}; retrying in {retry_in:.0f} s"


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


def _fmt(value: float | None, unit: str, digits: int = 1) -> str:
    return "unknown" if value is None else f"{value:.{digits}f} {unit}"


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
    stage = _number(telemetry, "stages.renderer")
    return round(age + (stage or 0.0), 3)


def tracker_of(state: Any) -> HealthTracker:
    tracker: HealthTracker | None = getattr(state, "wizard_health", None)
    if tracker is None:
        settings = getattr(state, "settings", None)
        limits = Thresholds.from_settings(settings) if settings is not None else Thresholds()
        tracker = state.wizard_health = HealthTracker(limits=limits)
    return tracker
