"""The booth check a technician runs before each participant (page ``/booths/<booth>/check``).

Each step is judged from what the booth's worker reports (its 1 Hz heartbeat), the robot
display's presence and the server's disk; the result (pass/fail per step, the figures) is
logged as a ``booth.checked`` event, with the session when one is given, so it is exported
with the session's events.

- **Face stream**: the phone's frames arrive (rate) and reach the robot quickly (capture to
  send latency).
- **Turn your head left, then nod**: the head's yaw and pitch extremes over the last
  seconds, against the expected sign and size. A turn of 20-90 degrees to the left is yaw >
  0 (nose to the camera's right), a nod of 8-60 degrees is pitch > 0 (chin down). A turn the
  wrong way is a sign or mirror error; one far beyond 90 degrees a unit error (radians read
  as degrees/180 copies a head turn about three times too large).
- **Robot**: connected (for the virtual robot: a display page open and playing).
- **Robot copies**: the copy behaviour runs, with its configured delay and the measured
  capture-to-send latency.
- **Disk**: free space where recordings are written; below the limit is a warning.
"""

from __future__ import annotations

import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from chameleons.backend.wizard import health

MIN_TURN_DEG, MAX_TURN_DEG = 20.0, 90.0
MIN_NOD_DEG, MAX_NOD_DEG = 8.0, 60.0
MAX_LATENCY_MS = 100.0
MIN_FREE_BYTES = 5 * 1024**3
PASS, FAIL, WARN = "pass", "fail", "warn"
CHECKED = "booth.checked"


def step(id_: str, label: str, status: str, value: str, **figures: Any) -> dict[str, Any]:
    return {"id": id_, "label": label, "status": status, "value": value, "figures": figures}


def face_stream(telemetry: Mapping[str, Any] | None) -> dict[str, Any]:
    label = "Face stream"
    if telemetry is None:
        return step("face", label, FAIL, "no worker for this booth")
    checks = health.evaluate(telemetry, 0.0)
    fps = _number(telemetry.get("input_fps"))
    latency = _number(telemetry.get("capture_to_send_ms"))
    if not checks["input"].ok:
        return step("face", label, FAIL, checks["input"].value, fps=fps, latency_ms=latency)
    slow = latency is not None and latency > MAX_LATENCY_MS
    value = f"{fps:.0f} fps, {latency:.0f} ms to the robot" if latency is not None else (
        f"{fps:.0f} fps")  # fmt: skip
    return step("face", label, WARN if slow else PASS, value, fps=fps, latency_ms=latency)


def head_turn(telemetry: Mapping[str, Any] | None) -> dict[str, Any]:
    label = "Turn your head left, then nod"
    ingest = (telemetry or {}).get("ingest")
    heads = ingest.get("head_range") if isinstance(ingest, Mapping) else None
    if not isinstance(heads, Mapping):
        return step("head", label, FAIL, "no head movement received")
    yaw_max, yaw_min = float(heads["yaw_max"]), float(heads["yaw_min"])
    pitch_max = float(heads["pitch_max"])
    figures = {"yaw_max": yaw_max, "yaw_min": yaw_min, "pitch_max": pitch_max,
               "expected_yaw": f"+{MIN_TURN_DEG:g}..{MAX_TURN_DEG:g}",
               "expected_pitch": f"+{MIN_NOD_DEG:g}..{MAX_NOD_DEG:g}"}  # fmt: skip
    measured = f"yaw {yaw_max:+.0f}, pitch {pitch_max:+.0f} degrees"
    if max(yaw_max, -yaw_min) > MAX_TURN_DEG:
        return step("head", label, FAIL, f"{measured}: far too large, check the rotation unit "
                    "(CHAMELEONS_LIVELINK_ROTATION_SCALE)", **figures)  # fmt: skip
    if yaw_max < MIN_TURN_DEG and -yaw_min >= MIN_TURN_DEG:
        return step("head", label, FAIL, f"yaw {yaw_min:+.0f}: the turn reads the wrong way, "
                    "check the mirror and mounting settings", **figures)  # fmt: skip
    if yaw_max < MIN_TURN_DEG:
        return step("head", label, FAIL, f"{measured}: no turn to the left seen", **figures)
    if pitch_max < MIN_NOD_DEG or pitch_max > MAX_NOD_DEG:
        return step("head", label, FAIL, f"{measured}: no nod seen", **figures)
    return step("head", label, PASS, measured, **figures)


def robot(telemetry: Mapping[str, Any] | None, display: tuple[bool, str] | None) -> dict[str, Any]:
    if telemetry is None:
        return step("robot", "Robot", FAIL, "no worker for this booth")
    check = health.evaluate(telemetry, 0.0, display=display)["robot"]
    return step("robot", "Robot", PASS if check.ok else FAIL, check.value)


def copies(telemetry: Mapping[str, Any] | None) -> dict[str, Any]:
    label = "Robot copies the head"
    if telemetry is None:
        return step("copy", label, FAIL, "no worker for this booth")
    behaviour = telemetry.get("behaviour")
    params = telemetry.get("behaviour_params")
    delay = _number(params.get("delay")) if isinstance(params, Mapping) else None
    latency = _number(telemetry.get("capture_to_send_ms"))
    if behaviour != "copy" or delay is None:
        return step("copy", label, WARN, f"the robot runs {behaviour or 'nothing'}, not copy",
                    behaviour=behaviour)  # fmt: skip
    measured = delay + (latency or 0.0) / 1000.0
    return step("copy", label, PASS, f"delay {delay:.3f} s configured, {measured:.3f} s "
                "measured (with capture to send)", delay_s=delay,
                measured_s=round(measured, 3))  # fmt: skip


def disk(data_dir: Path, minimum: int = MIN_FREE_BYTES) -> dict[str, Any]:
    where = data_dir if data_dir.exists() else data_dir.parent
    free = shutil.disk_usage(where).free
    gigabytes = free / 1024**3
    status = PASS if free >= minimum else WARN
    value = f"{gigabytes:.1f} GB free" + ("" if status == PASS else
                                          f", below {minimum / 1024**3:.0f} GB")  # fmt: skip
    return step("disk", "Disk space for recordings", status, value, free_bytes=free)


def run(
    telemetry: Mapping[str, Any] | None, display: tuple[bool, str] | None, data_dir: Path
) -> dict[str, Any]:
    steps = [face_stream(telemetry), head_turn(telemetry), robot(telemetry, display),
             copies(telemetry), disk(data_dir)]  # fmt: skip
    return {"passed": all(s["status"] != FAIL for s in steps), "steps": steps}


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None
