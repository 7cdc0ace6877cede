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
- **Robot copies**: the copy behaviour runs; its configured delay against the delay the
  worker measured movement to movement (:mod:`chameleons.worker.delay_probe`), within
  ``MAX_DELAY_ERROR_S``.
- **Test prompt**: the robot says a test prompt; its speech start and end must come back
  from the robot (for the virtual robot: from the display page) (:mod:`.speech_test`).
- **Disk**: the recordings folder can be written, and its free space covers a session
  (``Settings.session_disk_bytes``: recording rate x session length, both settings); less
  is a warning, a folder that cannot be written a failure.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from chameleons.backend.withdrawal.files import RECORDINGS_DIR
from chameleons.backend.wizard import health
from chameleons.worker.recording import write_problem

MIN_TURN_DEG, MAX_TURN_DEG = 20.0, 90.0
MIN_NOD_DEG, MAX_NOD_DEG = 8.0, 60.0
MAX_LATENCY_MS = 100.0
MAX_DELAY_ERROR_S = 0.25  # measured against configured copy delay
MIN_FREE_BYTES = 360 * 1000**2  # the settings' default: 100 kB/s for 60 minutes
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
    """The configured copy delay against the one measured movement to movement (the
    worker's probe: captured head yaw against the yaw sent to the robot)."""
    label = "Robot copies the head"
    if telemetry is None:
        return step("copy", label, FAIL, "no worker for this booth")
    behaviour = telemetry.get("behaviour")
    params = telemetry.get("behaviour_params")
    delay = _number(params.get("delay")) if isinstance(params, Mapping) else None
    if behaviour != "copy" or delay is None:
        return step("copy", label, WARN, f"the robot runs {behaviour or 'nothing'}, not copy",
                    behaviour=behaviour)  # fmt: skip
    probe = telemetry.get("movement_delay")
    measured = _number(probe.get("delay_s")) if isinstance(probe, Mapping) else None
    if measured is None:
        return step("copy", label, FAIL, f"delay {delay:.3f} s configured; no copy of a head "
                    "movement measured (turn the head, wait for the robot)",
                    delay_s=delay, measured_s=None)  # fmt: skip
    off = measured - delay
    status = PASS if abs(off) <= MAX_DELAY_ERROR_S else FAIL
    return step("copy", label, status, f"delay {delay:.3f} s configured, {measured:.3f} s "
                f"measured movement to movement ({off * 1000:+.0f} ms)", delay_s=delay,
                measured_s=measured,
                correlation=_number(probe.get("correlation")) if isinstance(probe, Mapping)
                else None)  # fmt: skip


def speech(result: Mapping[str, Any] | None) -> dict[str, Any]:
    """The test prompt: the robot (or the virtual robot's page) reported its speech start
    and end (:mod:`.speech_test`)."""
    label = "Robot says a test prompt"
    if result is None:
        return step("speech", label, WARN, "not run")
    started, ended = result.get("start_ms"), result.get("ended")
    figures = {"start_ms": started, "ended": ended, "prompt_id": result.get("prompt_id")}
    if result.get("problem"):
        return step("speech", label, FAIL, str(result["problem"]), **figures)
    if started is None:
        return step("speech", label, FAIL, "the robot never started speaking", **figures)
    if not ended:
        return step("speech", label, FAIL, f"started after {started:.0f} ms, never ended",
                    **figures)  # fmt: skip
    return step("speech", label, PASS, f"started after {started:.0f} ms and ended", **figures)


def disk(data_dir: Path, minimum: int = MIN_FREE_BYTES) -> dict[str, Any]:
    label = "Disk space for recordings"
    folder = data_dir / RECORDINGS_DIR
    where = next((p for p in (folder, data_dir, data_dir.parent) if p.exists()), Path("."))
    free = shutil.disk_usage(where).free
    needed = f"{minimum / 1000**2:,.0f} MB"
    try:  # root may write anywhere but a read-only mount: try it rather than ask
        with tempfile.TemporaryFile(dir=where, prefix=".booth-check-"):
            pass
    except OSError as exc:
        return step("disk", label, FAIL, write_problem(exc, where), free_bytes=free,
                    needed_bytes=minimum)  # fmt: skip
    status = PASS if free >= minimum else WARN
    value = f"{free / 1000**3:.1f} GB free" + (
        f" (a session needs about {needed})" if status == PASS
        else f", below the {needed} a session needs")  # fmt: skip
    return step("disk", label, status, value, free_bytes=free, needed_bytes=minimum)


def run(
    telemetry: Mapping[str, Any] | None, display: tuple[bool, str] | None, data_dir: Path,
    disk_needed: int = MIN_FREE_BYTES, spoken: Mapping[str, Any] | None = None,
) -> dict[str, Any]:  # fmt: skip
    steps = [face_stream(telemetry), head_turn(telemetry), robot(telemetry, display),
             copies(telemetry), speech(spoken), disk(data_dir, disk_needed)]  # fmt: skip
    return {"passed": all(s["status"] != FAIL for s in steps), "steps": steps}


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None
