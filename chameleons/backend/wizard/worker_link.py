"""The console's side of the worker bridge, written defensively.

``app.state.bridge`` may be missing or None (no worker runs), a command may time out, and
the bridge may raise. Every one of these becomes an :class:`Outcome` with a reason and a
sentence for the wizard, never an exception: the console keeps working and the timeline
says "not sent".
"""

from __future__ import annotations

import asyncio
import inspect
from typing import Any

from chameleons.backend.wizard.service import Outcome

COMMAND_TIMEOUT_SECONDS = 1.5
NO_BRIDGE = "no_worker"
TIMEOUT = "timeout"
UNREACHABLE = "unreachable"
REFUSED = "refused"
# Refusals whose detail is already a sentence for the wizard (e.g. "The disk is full ...").
SENTENCE_ERRORS = frozenset({"recording_failed"})


def bridge_of(state: Any) -> Any | None:
    return getattr(state, "bridge", None)


async def send_command(
    bridge: Any | None,
    booth: str,
    command: str,
    body: dict[str, Any],
    timeout: float = COMMAND_TIMEOUT_SECONDS,
) -> Outcome:
    """Send one command and wait for its acknowledgement; explain every failure."""
    if bridge is None:
        return Outcome(False, NO_BRIDGE, "No worker bridge on this server: worker unreachable.")
    try:
        answer = bridge.send_command(booth, command, body, timeout=timeout)
        if inspect.isawaitable(answer):
            answer = await asyncio.wait_for(answer, timeout + 0.5)
    except TimeoutError:
        return Outcome(
            False, TIMEOUT, f"The worker of {booth} did not answer within {timeout:g} s."
        )
    except Exception as exc:  # the bridge's own errors: unreachable, closed, bad booth...
        return Outcome(False, UNREACHABLE, f"Worker of {booth} unreachable: {exc}")
    return _from_ack(booth, answer)


def _from_ack(booth: str, answer: Any) -> Outcome:
    if answer is None:
        return Outcome(False, TIMEOUT, f"The worker of {booth} did not answer.")
    ok = _field(answer, "ok")
    if ok is True:
        result = _field(answer, "result")
        return Outcome(True, result=result if isinstance(result, dict) else {})
    error = str(_field(answer, "error") or REFUSED)
    detail = str(_field(answer, "detail") or "")
    if error in SENTENCE_ERRORS and detail:
        return Outcome(False, error, detail)
    return Outcome(False, error, f"The worker refused: {error}{': ' + detail if detail else ''}")


def _field(answer: Any, name: str) -> Any:
    if isinstance(answer, dict):
        return answer.get(name)
    return getattr(answer, name, None)


def latest_telemetry(bridge: Any | None, booth: str) -> tuple[dict[str, Any] | None, float | None]:
    """The booth's latest heartbeat and its age in seconds, ``(None, None)`` when none."""
    if bridge is None:
        return None, None
    reader = getattr(bridge, "latest_telemetry", None)
    if not callable(reader):
        return None, None
    try:
        answer = reader(booth)
    except Exception:  # a broken bridge reads as "no telemetry", which the strip shows
        return None, None
    if isinstance(answer, tuple) and len(answer) == 2:
        telemetry, age = answer
        return (dict(telemetry) if isinstance(telemetry, dict) else None,
                float(age) if isinstance(age, int | float) else None)  # fmt: skip
    return None, None
