"""The booth check a technician runs before each participant (page ``/booths/<booth>/check``).

Each step is judged from what the booth's worker reports (its 1 Hz heartbeat), the robot
display's presence and the server's disk; the result (pass/fail per step, the figures) is
logged as a ``booth.checked`` event, with the session when one is given, so it is exported
with the session's events.

- **Face stream**: the phone's frames arrive (rate) and reach the robot quickly (capture to
  send latency: the pipeline's own, without the copy's intended delay). A phone timecode
  the worker does not trust (frozen, jumping, drifting: it falls back to arrival times) is
  a warning with the reason.
- **Turn your head left, then nod**: the head's movement from its resting pose, which the
  worker measures while the check asks to hold still (a phone below or beside the face is
  a resting pose of +15 degrees pitch or 25 degrees yaw, not a nod or a turn). A turn of
  20-90 degrees to the left is yaw > 0 (nose to the camera's right), a nod of 8-60 degrees
  is pitch > 0 (chin down). A turn the wrong way is a sign or mirror error; one far beyond
  90 degrees a unit error (radians read as degrees/180 copies a head turn about three times
  too large).
  A movement too small to count that would be the right size times pi (degrees/180 read
  as radians) or 180/pi (radians read as degrees) says so: the unit is the likely cause.
- **Robot copies**: also fails when the robot is not logged in (a refused or unanswered
  Furhat login), with that reason: the worker measures the copy on what it sends, and a
  robot that refused the login receives none of it.
- **Robot**: connected (for the virtual robot: a display page open and playing). On a
  booth with both robots (``virtual+furhat``) the robot of the checked condition
  (:mod:`.check_robot`: the check runs on it), and the result says which
  (``checked_on``: "Checked on the Furhat").
  A display that painted fewer than ``MIN_DISPLAY_FPS`` frames a second over the check
  (the median of its page's 1 Hz reports) is a warning: it plays, but a participant sees a
  face that jumps (a background tab, a covered or minimised window, no graphics
  acceleration), which a single report cannot show.
- **Robot copies**: the check runs the robot in the chosen ``copy`` condition (default: the
  study's copy condition) with its full parameters while the head turns and nods
  (:mod:`.check_run`, which restores the behaviour before); the condition's delay against
  the delay the worker measured movement to movement (:mod:`chameleons.worker.delay_probe`),
  and its channels against what moved (:mod:`.check_copy`). No copy measured, or a delay
  outside the condition's (fixed: off by more than ``MAX_DELAY_ERROR_S``), fails.
- **Test prompt**: the robot says a test prompt; its speech start and end must come back
  from the robot (for the virtual robot: from the display page) (:mod:`.speech_test`).
- **Disk**: the recordings folder can be written, and its free space covers a session
  (``Settings.session_disk_bytes``: recording rate x session length, both settings); less
  is a warning, a folder that cannot be written a failure.
"""

from __future__ import annotations

import math
import shutil
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from chameleons.backend.booth import check_copy
from chameleons.backend.booth.check_copy import MAX_DELAY_ERROR_S as MAX_DELAY_ERROR_S
from chameleons.backend.withdrawal.files import RECORDINGS_DIR
from chameleons.backend.wizard import health
from chameleons.worker.recording import write_problem

MIN_TURN_DEG, MAX_TURN_DEG = 20.0, 90.0
MIN_NOD_DEG, MAX_NOD_DEG = 8.0, 60.0
MAX_LATENCY_MS = 100.0
MIN_DISPLAY_FPS = 10.0  # below this a face visibly jumps instead of moving
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
    ingest = telemetry.get("ingest")
    timecode = ingest.get("timecode_problem") if isinstance(ingest, Mapping) else None
    if timecode:
        return step("face", label, WARN, f"{value}; {timecode}: the copy runs on arrival times "
                    "(check the phone app's timecode source)", fps=fps, latency_ms=latency,
                    timecode=str(timecode))  # fmt: skip
    return step("face", label, WARN if slow else PASS, value, fps=fps, latency_ms=latency)


def expected_head() -> str:
    """What the head step wants, in the words the page and the command line show."""
    return (f"yaw +{MIN_TURN_DEG:g}..+{MAX_TURN_DEG:g}° (a turn to the left) and pitch "
            f"+{MIN_NOD_DEG:g}..+{MAX_NOD_DEG:g}° (a nod, chin down)")  # fmt: skip


def _head_value(turn: float, nod: float, rest: Mapping[str, Any]) -> str:
    """The measured turn and nod, each against its expected sign and size, and the resting
    pose they are measured from."""
    return (f"turn {turn:+.0f}° (expected +{MIN_TURN_DEG:g}..+{MAX_TURN_DEG:g}: turn left), "
            f"nod {nod:+.0f}° (expected +{MIN_NOD_DEG:g}..+{MAX_NOD_DEG:g}), from a resting "
            f"pose of yaw {float(rest['yaw']):+.0f}°, "
            f"pitch {float(rest['pitch']):+.0f}°")  # fmt: skip


def head_turn(telemetry: Mapping[str, Any] | None) -> dict[str, Any]:
    """The head's movement from the resting pose the worker measured at the movement's start
    (``head_range.rest``): extremes minus rest, so a phone mounted off-centre moves nothing."""
    label = "Turn your head left, then nod"
    ingest = (telemetry or {}).get("ingest")
    heads = ingest.get("head_range") if isinstance(ingest, Mapping) else None
    if not isinstance(heads, Mapping):
        return step("head", label, FAIL,
                    f"no head movement received (expected {expected_head()})")  # fmt: skip
    rest = heads.get("rest")
    if not isinstance(rest, Mapping):
        return step("head", label, FAIL, "no resting pose measured, so no movement can be "
                    f"judged (expected {expected_head()} from the pose held still "
                    "first)")  # fmt: skip
    yaw_max, yaw_min = float(heads["yaw_max"]), float(heads["yaw_min"])
    rest_yaw, rest_pitch = float(rest["yaw"]), float(rest["pitch"])
    left, right = yaw_max - rest_yaw, rest_yaw - yaw_min
    # The larger excursion either way: a turn read the wrong way shows as a negative turn.
    turn = left if left >= right else -right
    nod = float(heads["pitch_max"]) - rest_pitch
    figures = {"yaw_max": yaw_max, "yaw_min": yaw_min, "pitch_max": float(heads["pitch_max"]),
               "rest_yaw": rest_yaw, "rest_pitch": rest_pitch, "turn_deg": round(turn, 1),
               "nod_deg": round(nod, 1), "expected_yaw": f"+{MIN_TURN_DEG:g}..{MAX_TURN_DEG:g}",
               "expected_pitch": f"+{MIN_NOD_DEG:g}..{MAX_NOD_DEG:g}"}  # fmt: skip
    measured = _head_value(turn, nod, rest)
    if max(left, right) > MAX_TURN_DEG:
        return step("head", label, FAIL, f"{measured}: far too large, check the rotation unit "
                    "(CHAMELEONS_LIVELINK_ROTATION_SCALE)", **figures)  # fmt: skip
    if left < MIN_TURN_DEG and right >= MIN_TURN_DEG:
        return step("head", label, FAIL, f"{measured}: the turn reads the wrong way, "
                    "check the mirror and mounting settings", **figures)  # fmt: skip
    if left < MIN_TURN_DEG:
        hint = unit_hint(left, MIN_TURN_DEG, MAX_TURN_DEG, "turn")
        return step("head", label, FAIL, f"{measured}: no turn to the left seen{hint}",
                    **figures)  # fmt: skip
    if nod < MIN_NOD_DEG or nod > MAX_NOD_DEG:
        hint = unit_hint(nod, MIN_NOD_DEG, MAX_NOD_DEG, "nod")
        return step("head", label, FAIL, f"{measured}: no nod seen{hint}", **figures)
    return step("head", label, PASS, measured, **figures)


# A rotation read in the wrong unit is too small by one of these factors.
UNIT_MISTAKES = (
    (math.pi, "the phone sends degrees/180 and the worker reads radians"),
    (180.0 / math.pi, "the phone sends radians and the worker reads degrees"),
)


def unit_hint(measured: float, low: float, high: float, movement: str) -> str:
    """A hint when a movement too small to count is the expected size read in the wrong
    unit (empty when no unit mistake explains it)."""
    for factor, how in UNIT_MISTAKES:
        meant = measured * factor
        if measured > 0 and low <= meant <= high:
            return (f"; if the head moved about {meant:.0f}°, the rotation unit is wrong "
                    f"({how}: {factor:.3g} times too small): check "
                    "CHAMELEONS_LIVELINK_ROTATION_SCALE")  # fmt: skip
    return ""


def robot(
    telemetry: Mapping[str, Any] | None, display: tuple[bool, str] | None,
    checked: Mapping[str, Any] | None = None, paint_fps: float | None = None,
) -> dict[str, Any]:  # fmt: skip
    """The robot the check ran on (``checked``, :class:`.check_robot.Checked`): on a booth
    with both robots that one, driven now or not; else the booth's robot. ``paint_fps``:
    the display's median frames a second over the check, judged when the robot is the
    display."""
    if telemetry is None:
        return step("robot", "Robot", FAIL, "no worker for this booth")
    if checked and checked.get("problem"):
        return step("robot", "Robot", FAIL, str(checked["problem"]))
    output = checked.get("output") if checked else None
    if output:
        check = health.output_check(telemetry, str(output), display)
    else:
        check = health.evaluate(telemetry, 0.0, display=display)["robot"]
    value = f"{checked['words']}: {check.value}" if checked else check.value
    on_display = output == health.DISPLAY or (not output and telemetry.get("driver") == "virtual")
    if not on_display or paint_fps is None:
        return step("robot", "Robot", PASS if check.ok else FAIL, value)
    if check.ok and paint_fps < MIN_DISPLAY_FPS:
        return step("robot", "Robot", WARN, f"{value}, but it painted only {paint_fps:.0f} "
                    f"frames a second during the check (a face moves smoothly from about "
                    f"{MIN_DISPLAY_FPS:.0f}): give the display a full-screen window of its own "
                    "(a background tab or a covered or minimised window is slowed down by the "
                    "browser) on a machine with graphics acceleration",
                    display_fps=paint_fps)  # fmt: skip
    return step("robot", "Robot", PASS if check.ok else FAIL, value, display_fps=paint_fps)


@dataclass(frozen=True)
class Movement:
    """What the check saw while it ran the robot in ``copy`` (:mod:`.check_run`): the
    heartbeat after the head movement and the one after the robot's copy of it."""

    delay_s: float  # the condition's delay as one number (a distribution's mean)
    condition: str | None  # the study's condition it comes from (None: the worker's default)
    head: Mapping[str, Any] | None = None
    copy: Mapping[str, Any] | None = None
    problem: str | None = None  # why the robot could not be switched to copy
    params: Mapping[str, Any] | None = None  # the condition's params sent (None: delay only)
    words: str = ""  # the params in words (behaviour_words)
    flip: bool = False  # the condition mirrors unlike the booth: the copied yaw is negated
    robot: str = ""  # the robot it ran on, in words ("the Furhat")
    unreachable: str | None = None  # why it could not run on the condition's robot


def copies(telemetry: Mapping[str, Any] | None, movement: Movement | None) -> dict[str, Any]:
    """The condition's copy against what the worker measured movement to movement (its
    probe: captured head yaw against the yaw sent to the robot; the brows raised against the
    robot's brows), while the check ran the robot in the condition
    (:mod:`.check_copy` says what is judged). Not copying, or a delay outside the
    condition's, fails."""
    label = "Robot copies the head"
    if telemetry is None:
        return step("copy", label, FAIL, "no worker for this booth")
    if movement is None:
        return step("copy", label, FAIL, "not run: the check ran without the head movement")
    params = dict(movement.params) if movement.params is not None else {
        "delay": movement.delay_s}  # fmt: skip
    delay = movement.delay_s
    figures: dict[str, Any] = {"delay_s": delay, "measured_s": None,
                               "condition": movement.condition, "params": params,
                               "behaviour_words": movement.words,
                               "robot": movement.robot or None}  # fmt: skip
    if movement.unreachable:
        return step("copy", label, FAIL, f"not run: {movement.unreachable}", **figures)
    low, high = check_copy.delay_range(params)
    late = f"delay {delay:.2f} s" if low == high else f"delay {low:.2f}-{high:.2f} s"
    configured = f"{late} configured" + (
        f" ({movement.condition}: {movement.words})" if movement.condition and movement.words
        else f" ({movement.condition})" if movement.condition else " (the worker's default)"
    )  # fmt: skip
    note = check_copy.what_is_copied(params)
    configured += f"; {note}" if note else ""
    configured += f"; checked on {movement.robot}" if movement.robot else ""
    if movement.problem:
        return step("copy", label, FAIL, f"the robot could not be switched to copy: "
                    f"{movement.problem}", **figures)  # fmt: skip
    latest = movement.copy or telemetry
    if latest.get("robot_connected") is False:  # the copy is measured on what is sent
        return step("copy", label, FAIL, f"{configured}; the robot cannot copy: "
                    f"{health.robot_value(latest, False)}", **figures)  # fmt: skip
    seen = movement.copy or {}
    if seen.get("behaviour") != "copy":
        return step("copy", label, FAIL, f"{configured}; the robot ran "
                    f"{seen.get('behaviour') or 'nothing'}, not copy", **figures)  # fmt: skip
    brow_status, brow_words = check_copy.judge_brows(params, _mapping(seen.get("movement_brows")))
    figures["brows"] = seen.get("movement_brows")
    probe = seen.get("movement_delay")
    gain_status, gain_words = check_copy.judge_gain(
        params, _mapping(probe), _mapping(seen.get("movement_brows"))
    )
    figures.update(gain=params.get("gain", 1.0),
                   measured_gain=_number(probe.get("gain")) if isinstance(probe, Mapping)
                   else None)  # fmt: skip
    if gain_status == FAIL:
        brow_status = FAIL  # the brows' and the head's gain fail the step alike
    brow_part = "".join(f"; {w}" for w in (brow_words, gain_words) if w)
    measured = _number(probe.get("delay_s")) if isinstance(probe, Mapping) else None
    if not check_copy.copies_head_turn(params):
        status = FAIL if brow_status == FAIL else WARN if brow_status != PASS else PASS
        return step("copy", label, status, f"{configured}; this condition does not copy the "
                    f"head turn, so its delay is not judged{brow_part}", **figures)  # fmt: skip
    if measured is None:
        if params.get("intermittent"):
            return step("copy", label, WARN, f"{configured}; no copied bout was measured (the "
                        "movement fell into a rest between bouts: run the check again)"
                        f"{brow_part}", **figures)  # fmt: skip
        return step("copy", label, FAIL, f"{configured}; the robot did not copy the head "
                    "movement (none measured: was the head turned?)", **figures)  # fmt: skip
    figures.update(measured_s=measured, tolerance_s=MAX_DELAY_ERROR_S,
                   correlation=_number(probe.get("correlation"))
                   if isinstance(probe, Mapping) else None)  # fmt: skip
    fits, measured_words = check_copy.judge_delay(params, measured)
    mirrored = bool(probe.get("mirrored")) if isinstance(probe, Mapping) else False
    if mirrored != movement.flip:
        fits = False
        measured_words += ("; the robot's copied head turned the wrong way for the condition's "
                           "mirror setting (and the booth's)")  # fmt: skip
    status = PASS if fits and brow_status != FAIL else FAIL
    return step("copy", label, status, f"{configured}, {measured_words}{brow_part}",
                **figures)  # fmt: skip


def _mapping(value: Any) -> Mapping[str, Any] | None:
    return value if isinstance(value, Mapping) else None


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
    movement: Movement | None = None, checked: Mapping[str, Any] | None = None,
    paint_fps: float | None = None,
) -> dict[str, Any]:  # fmt: skip
    """Every step; the head step reads the heartbeat taken right after the head movement
    when there was one (its window would lose the turn while the robot copies it).
    ``checked``: the robot the check ran on (:class:`.check_robot.Checked`), said in the
    result as ``checked_on`` ("Checked on the Furhat"); ``paint_fps``: the display's median
    frames a second over the check (:meth:`DisplayChannel.paint_rate`)."""
    head = movement.head if movement is not None and movement.head is not None else telemetry
    steps = [face_stream(telemetry), head_turn(head), robot(telemetry, display, checked, paint_fps),
             copies(telemetry, movement), speech(spoken), disk(data_dir, disk_needed)]  # fmt: skip
    result = {"passed": all(s["status"] != FAIL for s in steps), "steps": steps}
    if checked:
        problem = checked.get("problem")
        result["checked_on"] = (f"Not checked on {checked['words']}: {problem}" if problem
                                else f"Checked on {checked['words']}")  # fmt: skip
        result["robot"] = dict(checked)
    return result


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None
