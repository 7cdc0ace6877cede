"""The robot chips of the health strip: *Robot* (the robot driven now), on a booth with
both robots (driver virtual+furhat) *Robot display* and *Furhat* for the one a later
condition needs, and *Typed speech* (whether the Say field can speak). The booth check
(:mod:`chameleons.backend.booth.check`) judges a robot with :func:`output_check` and
words a robot's connection with :func:`robot_value` too.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from chameleons.backend.wizard.health_checks import (
    DISPLAY,
    FURHAT,
    ROBOT_NAMES,
    ROBOT_PROBLEMS,
    Check,
    Needs,
    number,
)
from chameleons.worker.drivers import renderers, speaks_text


def typed_speech_check(
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

def robot_check(
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


def needed_robots(
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
    retry_in = number(telemetry, "robot_retry_in")
    if state == "connecting" and problem:  # a login that failed is being tried again
        return f"login failed: {problem}; trying again now"
    if state in ROBOT_PROBLEMS:
        value = f"{ROBOT_PROBLEMS[state]}: {problem}" if problem else ROBOT_PROBLEMS[state]
    else:
        value = "disconnected"
    return value if retry_in is None else f"{value}; retrying in {retry_in:.0f} s"

